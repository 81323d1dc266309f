"""Thrusters as model data (uvms.dynamics.thrusters) and their first-order dynamics in the plant."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import uvms
from conftest import THRUSTER_BOX
from uvms.dynamics.actuated import ActuatedCommand, ActuatedPlant
from uvms.dynamics.hydrodynamics import HydroParameters
from uvms.dynamics.plant import Plant
from uvms.dynamics.thrusters import allocation_matrix, load_thrusters_yaml, parse_thrusters_urdf, thrusters_of
from uvms.errors import ModelCheckError
from uvms.sim import simulate

S = np.sqrt(0.5)

#: B of tests/dynamics/thruster_box.urdf derived by hand: a horizontal thruster at (x, y, 0) pushing along
#: (cos t, sin t, 0) gives [cos t, sin t, 0, 0, 0, x sin t - y cos t]; a vertical one at (x, y, 0) pushing
#: up gives [0, 0, 1, y, -x, 0].
BOX_MATRIX = np.array([
    [S, S, -S, -S, 0, 0, 0, 0],
    [S, -S, S, -S, 0, 0, 0, 0],
    [0, 0, 0, 0, 1, 1, 1, 1],
    [0, 0, 0, 0, -0.15, 0.15, -0.15, 0.15],
    [0, 0, 0, 0, -0.15, -0.15, 0.15, 0.15],
    [0.3 * S, -0.3 * S, -0.3 * S, 0.3 * S, 0, 0, 0, 0],
])


@pytest.fixture(scope="module")
def box() -> uvms.Robot:
    return uvms.load(THRUSTER_BOX)


@pytest.fixture(scope="module")
def bluerov() -> uvms.Robot:
    return uvms.load("bluerov2_alpha5")


def test_box_allocation_matrix_equals_the_hand_derivation(box):
    thrusters = thrusters_of(box)
    assert thrusters.names == [f"thruster_{i}" for i in range(1, 9)]
    np.testing.assert_allclose(allocation_matrix(box, thrusters), BOX_MATRIX, atol=1e-12)
    np.testing.assert_array_equal(thrusters.lower, -40.0)
    np.testing.assert_array_equal(thrusters.upper, 50.0)
    np.testing.assert_array_equal(thrusters.time_constants, [0.1] * 4 + [0.2] * 4)


def test_yaml_form_gives_the_same_matrix_as_the_plugin_form(box, tmp_path):
    text = "max_forward: 50\nmax_reverse: 40\ntime_constant: 0.1\nthrusters:\n"
    for i, (x, y, yaw) in enumerate([(0.2, -0.1, 45), (0.2, 0.1, -45), (-0.2, -0.1, 135), (-0.2, 0.1, -135)], 1):
        text += f"  t{i}: {{parent: base_link, xyz: [{x}, {y}, 0], rpy: [0, 0, {float(np.radians(yaw))!r}]}}\n"
    for i, (x, y) in enumerate([(0.15, -0.15), (0.15, 0.15), (-0.15, -0.15), (-0.15, 0.15)], 5):
        text += f"  t{i}: {{parent: base_link, xyz: [{x}, {y}, 0], direction: [0, 0, 2.5]}}\n"
    path = tmp_path / "thrusters.yaml"
    path.write_text(text)
    thrusters = load_thrusters_yaml(path, box.frame_names)
    np.testing.assert_allclose(allocation_matrix(box, thrusters), BOX_MATRIX, atol=1e-12)
    frames = load_thrusters_yaml(_write(tmp_path, "thrusters:\n  a: {frame: thruster_3, max_forward: 5, "
                                                  "max_reverse: 4, time_constant: 0.1}\n"), box.frame_names)
    np.testing.assert_allclose(allocation_matrix(box, frames)[:, 0], BOX_MATRIX[:, 2], atol=1e-12)


def test_bluerov2_heavy_reproduces_ardusub_vectored_6dof_factors(bluerov):
    """The signs of B (FLU -> ArduSub's FRD: y, z negated; throttle = up) are ArduSub's motor factors."""
    thrusters = thrusters_of(bluerov)
    assert len(thrusters) == 8 and thrusters.source.endswith("thrusters.yaml")
    np.testing.assert_allclose(thrusters.upper, 51.5)
    np.testing.assert_allclose(thrusters.lower, -40.2)
    frd = np.diag([1, -1, -1, 1, -1, -1]) @ allocation_matrix(bluerov, thrusters)
    # rows: roll, pitch, yaw, throttle, forward, lateral (AP_Motors6DOF.cpp, SUB_FRAME_VECTORED_6DOF)
    factors = np.array([[0, 0, 1, 0, -1, 1], [0, 0, -1, 0, -1, -1], [0, 0, -1, 0, 1, 1], [0, 0, 1, 0, 1, -1],
                        [1, -1, 0, -1, 0, 0], [-1, -1, 0, -1, 0, 0], [1, 1, 0, -1, 0, 0], [-1, 1, 0, -1, 0, 0]]).T
    ours = np.vstack([frd[3], frd[4], frd[5], -frd[2], frd[0], frd[1]])
    np.testing.assert_array_equal(np.sign(np.round(ours, 12)), factors)
    assert np.linalg.matrix_rank(allocation_matrix(bluerov, thrusters)) == 6


def _write(folder: Path, text: str, name: str = "t.yaml") -> Path:
    path = folder / name
    path.write_text(text)
    return path


@pytest.mark.parametrize("entry, message", [
    ("{parent: base_link, direction: [0, 0, 0], max_forward: 5, max_reverse: 4, time_constant: 0.1}",
     "thrust direction [0.0, 0.0, 0.0] is zero"),
    ("{parent: base_link, max_forward: 5, max_reverse: -4, time_constant: 0.1}", "max_reverse must be >= 0"),
    ("{parent: base_link, max_forward: 0, max_reverse: 4, time_constant: 0.1}", "max_forward must be > 0"),
    ("{parent: base_link, max_forward: 5, max_reverse: 4, time_constant: 0}", "time_constant must be > 0"),
    ("{parent: base_lnk, max_forward: 5, max_reverse: 4, time_constant: 0.1}",
     "unknown frame 'base_lnk'; close names: base_link"),
    ("{parent: base_link, max_forward: 5, time_constant: 0.1}", "max_reverse is missing"),
    ("{parent: base_link, dirction: [1, 0, 0], max_forward: 5, max_reverse: 4, time_constant: 0.1}",
     "unknown key(s) dirction"),
])
def test_bad_yaml_thruster_names_the_file_and_the_valid_form(box, tmp_path, entry, message):
    path = _write(tmp_path, f"thrusters:\n  bad: {entry}\n")
    with pytest.raises(ModelCheckError) as error:
        load_thrusters_yaml(path, box.frame_names)
    text = str(error.value)
    assert message in text and str(path) in text and "thruster 'bad'" in text
    assert "max_forward > 0 N, max_reverse >= 0 N" in text  # the valid form


def test_bad_plugin_thrusters(box):
    urdf = THRUSTER_BOX.read_text()
    with pytest.raises(ModelCheckError, match="unknown frame 'thrster_1'; close names: thruster_1"):
        parse_thrusters_urdf(urdf.replace("<linkName>thruster_1<", "<linkName>thrster_1<"), "box", box.frame_names)
    with pytest.raises(ModelCheckError, match="thrustMin.*thrustMax.*needed"):
        parse_thrusters_urdf(urdf.replace("<thrustMin>-40</thrustMin>", "", 1), "box", box.frame_names)
    with pytest.raises(ModelCheckError, match="'ZeroOrder' is not supported.*FirstOrder"):
        parse_thrusters_urdf(urdf.replace("FirstOrder", "ZeroOrder", 1), "box", box.frame_names)
    with pytest.raises(ModelCheckError, match="-thrustMin must be >= 0"):
        parse_thrusters_urdf(urdf.replace("<thrustMin>-40<", "<thrustMin>5<", 1), "box", box.frame_names)


def test_thruster_on_an_arm_link_is_refused(bluerov, tmp_path):
    path = _write(tmp_path, "thrusters:\n  t: {parent: alpha_m1_link, max_forward: 5, max_reverse: 4, "
                            "time_constant: 0.1}\n")
    with pytest.raises(ModelCheckError, match="must be fixed to the vehicle body"):
        allocation_matrix(bluerov, thrusters_of(bluerov, path))


def test_models_without_thrusters_say_so():
    robot = uvms.load("amundsen2018")
    assert len(thrusters_of(robot, required=False)) == 0
    with pytest.raises(uvms.UVMSError, match="has no thrusters"):
        thrusters_of(robot)


# ------------------------------------------------------------------ thruster dynamics in the plant
class OpenLoop:
    """Sinusoidal thrust and arm commands (some beyond the limits, to exercise the saturation)."""

    def __init__(self, n_arm: int, n: int) -> None:
        self.n_arm, self.n = n_arm, n

    def __call__(self, t, q, v, thrusts):
        phase = np.arange(self.n)
        thrust = 60.0 * np.sin(2.0 * t + phase)  # beyond +50 / -40: clipped
        arm = 0.3 * np.sin(1.5 * t + np.arange(self.n_arm))
        return ActuatedCommand(arm, thrust, {})


def test_first_order_response_and_saturation(box):
    plant = Plant(box, HydroParameters())
    result = simulate(ActuatedPlant(plant, thrusters_of(box)), lambda t, q, v, f: ActuatedCommand(
        np.zeros(0), np.full(8, 100.0), {}), box.neutral(), 0.4, 0.001)
    thrusts = result.actuation.thrusts
    expected = 50.0 * (1.0 - np.exp(-result.t[:, None] / np.array([0.1] * 4 + [0.2] * 4)))  # command clipped to 50
    np.testing.assert_allclose(thrusts, expected, atol=1e-9)
    np.testing.assert_array_equal(result.actuation.thrust_command, 50.0)
    assert result.actuation_metrics()["max_thrust_ratio"] <= 1.0


def test_energy_balance_with_thrusters_arm_damping_and_restoring(bluerov):
    """kinetic + potential energy change = thruster work + motor work + damping work (no current)."""
    plant = Plant(bluerov, gravity=True)
    q0 = bluerov.configuration(base=[0, 0, 0, 0.1, -0.05, 0.2], arm=[3.0, 1.8, 1.8, 1.0, 0.005])
    result = simulate(ActuatedPlant(plant, thrusters_of(bluerov)), OpenLoop(bluerov.n_arm, 8), q0, 2.0, 0.002)
    a = result.actuation
    power = a.thrust_power + a.motor_power + a.damping_power
    work = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * np.diff(result.t))])
    energy = result.plant.energy - result.plant.energy[0]
    residual = np.max(np.abs(energy - work))
    thrust_work = np.sum(0.5 * (a.thrust_power[1:] + a.thrust_power[:-1]) * np.diff(result.t))
    dissipated = -np.sum(0.5 * (a.damping_power[1:] + a.damping_power[:-1]) * np.diff(result.t))
    assert thrust_work > 5.0 and dissipated > 1.0  # the terms are not trivially small
    assert residual < 1e-4 * thrust_work, (residual, thrust_work, dissipated)
    np.testing.assert_array_less(np.abs(a.thrusts), 51.5 + 1e-9)
    assert result.actuation_metrics()["saturated_time_fraction"] > 0.3


def test_plugin_joint_axis_gives_the_thrust_direction(box):
    """uuv_simulator pushes along the thruster joint's axis: with <jointName>, the axis (in the child link's
    frame) is the direction. Thruster 1 is yawed 45 deg: its link's y axis is (-s, s, 0) in the base."""
    urdf = THRUSTER_BOX.read_text().replace(
        '<origin xyz="0.2 -0.1 0" rpy="0 0 0.7853981633974483"/>',
        '<origin xyz="0.2 -0.1 0" rpy="0 0 0.7853981633974483"/><axis xyz="0 2 0"/>').replace(
        "<linkName>thruster_1</linkName>", "<linkName>thruster_1</linkName><jointName>thruster_1_joint</jointName>")
    thrusters = parse_thrusters_urdf(urdf, "box", box.frame_names)
    np.testing.assert_allclose(allocation_matrix(box, thrusters)[:, 0], [-S, S, 0, 0, 0, 0.2 * S - 0.1 * S],
                               atol=1e-12)
    with pytest.raises(ModelCheckError, match="unknown joint 'thruster_1_jont'; close names: thruster_1_joint"):
        parse_thrusters_urdf(urdf.replace("<jointName>thruster_1_joint<", "<jointName>thruster_1_jont<"), "box",
                             box.frame_names)
    with pytest.raises(ModelCheckError, match="jointName 'thruster_2_joint' does not carry linkName 'thruster_1'"):
        parse_thrusters_urdf(urdf.replace("<jointName>thruster_1_joint<", "<jointName>thruster_2_joint<"), "box",
                             box.frame_names)
