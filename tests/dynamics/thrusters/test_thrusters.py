"""Thrusters as model data (uvms.dynamics.thrusters.thrusters) and their first-order dynamics in the plant."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import uvms
from uvms.control import OpenLoop
from uvms.dynamics.hydro.hydrodynamics import HydroParameters
from uvms.dynamics.plant.actuated import ActuatedPlant, damping_power
from uvms.dynamics.plant.plant import Plant
from uvms.dynamics.thrusters.thrusters import (
    allocation_matrix,
    load_thrusters_yaml,
    parse_thrusters_urdf,
    thruster_rows,
    thrusters_of,
)
from uvms.errors import ModelCheckError, PointMassWarning, ThrusterDefaultWarning
from uvms.sim import simulate

from conftest import THRUSTER_BOX

S = np.sqrt(0.5)

#: B of tests/dynamics/thrusters/thruster_box.urdf derived by hand: a horizontal thruster at (x, y, 0) pushing along
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
    with pytest.raises(ModelCheckError, match="thruster plugin 'thruster_1': its lowest thrust is 5 N; it must be "
                                              "<= 0 N"):
        parse_thrusters_urdf(urdf.replace("<thrustMin>-40<", "<thrustMin>5<", 1), "box", box.frame_names)
    with pytest.raises(ModelCheckError, match=r"thrustMin \(60 N\) must be below thrustMax \(50 N\)"):
        parse_thrusters_urdf(urdf.replace("<thrustMin>-40<", "<thrustMin>60<", 1), "box", box.frame_names)
    with pytest.raises(ModelCheckError, match="<thrustMax> must be a number, got 'lots'"):
        parse_thrusters_urdf(urdf.replace("<thrustMax>50<", "<thrustMax>lots<", 1), "box", box.frame_names)


def test_a_missing_limit_or_a_zero_order_dynamics_takes_the_default_with_one_warning(box):
    """Without thrustMin the plugin leaves the reverse thrust unbounded (uuv_simulator's default), and ZeroOrder (no
    lag) is no time constant: both take uvms's RexROV defaults, named in one warning; the rest stays the plugin's."""
    urdf = THRUSTER_BOX.read_text().replace("<thrustMin>-40</thrustMin>", "", 1).replace(
        "<type>FirstOrder</type><timeConstant>0.2</timeConstant>", "<type>ZeroOrder</type>", 1)
    with pytest.warns(ThrusterDefaultWarning) as caught:
        thrusters = parse_thrusters_urdf(urdf, "box", box.frame_names)
    assert len(caught) == 1
    assert ("box: uvms's default thruster values for what neither the thruster plugins nor a thrusters.yaml beside "
            "the model give: max_reverse = 2000 N for thruster_1; time_constant = 0.05 s for thruster_5.") \
        in str(caught[0].message)
    np.testing.assert_array_equal(thrusters.lower, [-2000.0] + [-40.0] * 7)
    np.testing.assert_array_equal(thrusters.upper, 50.0)
    np.testing.assert_array_equal(thrusters.time_constants, [0.1] * 4 + [0.05, 0.2, 0.2, 0.2])


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
def sinusoids(n_arm: int, n: int) -> OpenLoop:
    """Sinusoidal thrust and arm commands (some beyond the limits, to exercise the saturation)."""
    return OpenLoop(thrust=lambda t: 60.0 * np.sin(2.0 * t + np.arange(n)),  # beyond +50 / -40: clipped
                    arm=lambda t: 0.3 * np.sin(1.5 * t + np.arange(n_arm)))


def test_first_order_response_and_saturation(box):
    plant = Plant(box, HydroParameters())
    result = simulate(ActuatedPlant(plant, thrusters_of(box)), OpenLoop(arm=np.zeros(0), thrust=np.full(8, 100.0)),
                      box.neutral(), 0.4, 0.001)
    thrusts = result.actuation.thrusts
    expected = 50.0 * (1.0 - np.exp(-result.t[:, None] / np.array([0.1] * 4 + [0.2] * 4)))  # command clipped to 50
    np.testing.assert_allclose(thrusts, expected, atol=1e-9)
    np.testing.assert_array_equal(result.actuation.thrust_command, 50.0)
    assert result.actuation_metrics()["max_thrust_ratio"] <= 1.0


def test_energy_balance_with_thrusters_arm_damping_and_restoring(bluerov):
    """kinetic + potential energy change = thruster work + motor work + damping work (no current)."""
    plant = Plant(bluerov, gravity=True)
    q0 = bluerov.configuration(base=[0, 0, 0, 0.1, -0.05, 0.2], arm=[3.0, 1.8, 1.8, 1.0, 0.005])
    result = simulate(ActuatedPlant(plant, thrusters_of(bluerov)), sinusoids(bluerov.n_arm, 8), q0, 2.0, 0.002)
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


# ------------------------------------------------------------------ uuv_simulator's plugins, completed per thruster
FOUR = Path(__file__).resolve().parents[2] / "fixtures" / "uuv" / "four_thrusters.urdf"
#: B of four_thrusters.urdf by hand: column [d; p x d] of a thruster at p pushing along d (base frame).
FOUR_MATRIX = np.array([
    # +x at (0.5, 0.3, 0.1), +y at (0.5, -0.3, 0.1), +z at (-0.4, 0, 0.2), -x at (-0.4, 0.2, -0.1)
    [1, 0, 0, -1],
    [0, 1, 0, 0],
    [0, 0, 1, 0],
    [0, -0.1, 0, 0],
    [0.1, 0, 0.4, 0.1],
    [-0.3, 0.5, 0, 0.2],
])


def four_thrusters(folder: Path, yaml: str | None = None, urdf: str | None = None) -> uvms.Robot:
    """The fixture copied into ``folder`` (with a thrusters.yaml beside it when given), loaded."""
    (folder / "rov.urdf").write_text(FOUR.read_text() if urdf is None else urdf)
    if yaml is not None:
        (folder / "thrusters.yaml").write_text(yaml)
    with pytest.warns(uvms.errors.PointMassWarning):
        return uvms.load(folder / "rov.urdf")


def test_uuv_plugins_without_limits_take_the_defaults_and_give_the_hand_derived_matrix(tmp_path):
    robot = four_thrusters(tmp_path)
    assert robot.n_arm == 0  # the propeller joints are written fixed here
    with pytest.warns(ThrusterDefaultWarning, match="max_forward = 2000 N for thruster_0, thruster_1, thruster_2; "
                      "max_reverse = 2000 N for thruster_0, thruster_1, thruster_2, thruster_3; time_constant = "
                      "0.05 s for thruster_2") as caught:
        thrusters = thrusters_of(robot)
    assert len(caught) == 1
    np.testing.assert_allclose(allocation_matrix(robot, thrusters), FOUR_MATRIX, atol=1e-12)
    np.testing.assert_array_equal(thrusters.upper, [2000, 2000, 2000, 300])  # thruster 3's plugin gives 300 N
    np.testing.assert_array_equal(thrusters.lower, -2000.0)
    np.testing.assert_array_equal(thrusters.time_constants, [0.1, 0.2, 0.05, 0.05])  # 2 is ZeroOrder


def test_a_yaml_beside_the_plugins_completes_them_per_thruster_and_wins_over_them(tmp_path, recwarn):
    yaml = ("max_forward: 150\nmax_reverse: 120\ntime_constant: 0.4\nthrusters:\n"
            "  thruster_0: {max_forward: 100, max_reverse: 80}\n"
            "  thruster_2: {time_constant: 0.3}\n"
            "  thruster_3: {max_forward: 250}\n")  # the plugin says 300: the user's YAML wins
    robot = four_thrusters(tmp_path, yaml)
    thrusters = thrusters_of(robot)
    np.testing.assert_array_equal(thrusters.upper, [100, 150, 150, 250])
    np.testing.assert_array_equal(thrusters.lower, [-80, -120, -120, -120])
    np.testing.assert_array_equal(thrusters.time_constants, [0.1, 0.2, 0.3, 0.05])  # file default 0.4: unused
    assert thrusters.source == f"{tmp_path / 'rov.urdf'} + {tmp_path / 'thrusters.yaml'}"
    np.testing.assert_allclose(allocation_matrix(robot, thrusters), FOUR_MATRIX, atol=1e-12)
    assert not [w for w in recwarn if issubclass(w.category, ThrusterDefaultWarning)]


def test_file_defaults_alone_complete_every_plugin_but_not_what_a_plugin_gives(tmp_path):
    robot = four_thrusters(tmp_path, "max_forward: 150\nmax_reverse: 120\ntime_constant: 0.4\n")
    thrusters = thrusters_of(robot)
    np.testing.assert_array_equal(thrusters.upper, [150, 150, 150, 300])
    np.testing.assert_array_equal(thrusters.lower, -120.0)
    np.testing.assert_array_equal(thrusters.time_constants, [0.1, 0.2, 0.4, 0.05])
    other = tmp_path / "elsewhere.yaml"
    other.write_text("thrusters:\n  thruster_1: {max_reverse: 7}\n")
    with pytest.warns(ThrusterDefaultWarning, match=f"nor {other} give: max_forward = 2000 N for thruster_0, "
                                                    "thruster_1, thruster_2; max_reverse = 2000 N for thruster_0, "
                                                    "thruster_2, thruster_3;"):
        chosen = thrusters_of(robot, other)  # path= replaces the YAML beside the model
    np.testing.assert_array_equal(chosen.lower, [-2000, -7, -2000, -2000])


@pytest.mark.parametrize("entry, message", [
    ("thruster_O: {max_forward: 5}", r"thruster 'thruster_O': no thruster plugin of the model has this name; an "
                                     r"entry completes the plugin of the same name: thruster_0, thruster_1, "
                                     r"thruster_2, thruster_3$"),
    ("thruster_1: {parent: rov/base_link, max_forward: 5}", r"thruster 'thruster_1': it completes the thruster "
     r"plugin 'thruster_1', whose link gives the pose; give only max_forward, max_reverse, time_constant \(not "
     r"parent\)"),
    ("thruster_1: {max_reverse: -3}", r"thrusters.yaml: thruster 'thruster_1': max_reverse must be >= 0, got -3"),
    ("thruster_1: 12", r"thruster 'thruster_1': expected a mapping, got 12"),
])
def test_a_bad_completion_is_refused_naming_the_file(tmp_path, entry, message):
    robot = four_thrusters(tmp_path, f"max_forward: 1\nmax_reverse: 1\nthrusters:\n  {entry}\n")
    with pytest.raises(ModelCheckError, match=message) as error:
        thrusters_of(robot)
    assert str(tmp_path) in str(error.value)


def test_a_bad_file_default_in_a_completion_is_refused_naming_the_file(tmp_path):
    robot = four_thrusters(tmp_path, "max_forward: -1\n")
    with pytest.raises(ModelCheckError, match=r"thrusters.yaml: max_forward must be > 0, got -1"):
        thrusters_of(robot)


def test_a_propeller_joint_must_be_frozen_and_the_thrust_acts_at_the_joints_zero(tmp_path):
    """uuv_simulator writes the propeller joint continuous (and the thruster link a point mass). The loader freezes
    it: the link is fixed to the vehicle at the joint's zero and B is the hand-derived one. Kept moving
    (``arm_joints=``), the thruster rides an arm joint and is refused with a message that says so."""
    urdf = FOUR.read_text().replace('type="fixed"', 'type="continuous"')
    (tmp_path / "rov.urdf").write_text(urdf)
    (tmp_path / "thrusters.yaml").write_text("max_forward: 150\nmax_reverse: 120\ntime_constant: 0.4\n")
    with pytest.warns(PointMassWarning, match="rov/thruster_0, rov/thruster_1"):  # the thruster links
        robot = uvms.load(tmp_path / "rov.urdf")
    assert robot.joint_classes["rov/thruster_0_joint"].kind == "propeller" and robot.n_arm == 0
    np.testing.assert_allclose(allocation_matrix(robot, thrusters_of(robot)), FOUR_MATRIX, atol=1e-12)
    (tmp_path / "rov.urdf").write_text(urdf.replace('ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"',
                                                    'ixx="1e-6" ixy="0" ixz="0" iyy="1e-6" iyz="0" izz="1e-6"'))
    moving = uvms.load(tmp_path / "rov.urdf", arm_joints=["rov/thruster_0_joint"])
    with pytest.raises(ModelCheckError, match=r"thruster 'thruster_0' is on frame 'rov/thruster_0', which moves "
                       r"with joint 'rov/thruster_0_joint'; a thruster must be fixed to the vehicle body .*; if "
                       r"'rov/thruster_0_joint' is the thruster's propeller joint .* it must be frozen in the "
                       r"loaded model"):
        allocation_matrix(moving, thrusters_of(moving))


def test_thruster_rows_give_the_base_frame_placements_and_limits(tmp_path):
    robot = four_thrusters(tmp_path, "max_forward: 150\nmax_reverse: 120\ntime_constant: 0.4\n")
    rows = thruster_rows(robot, thrusters_of(robot))
    assert [row["name"] for row in rows] == ["thruster_0", "thruster_1", "thruster_2", "thruster_3"]
    assert rows[1]["frame"] == "rov/thruster_1"
    np.testing.assert_allclose([row["position"] for row in rows],
                               [[0.5, 0.3, 0.1], [0.5, -0.3, 0.1], [-0.4, 0, 0.2], [-0.4, 0.2, -0.1]], atol=1e-12)
    np.testing.assert_allclose([row["direction"] for row in rows], FOUR_MATRIX[:3].T, atol=1e-12)
    assert [(row["max_forward"], row["max_reverse"], row["time_constant"]) for row in rows] == [
        (150, 120, 0.1), (150, 120, 0.2), (150, 120, 0.4), (300, 120, 0.05)]


def test_damping_power_is_derived_from_the_stored_states_link_by_link(bluerov):
    """The run's damping power, derived after the loop from the stored (q, v) of every row at once, is per row
    sum_l f_D,l(nu_r,l) . nu_l with each link's twist from Pinocchio's frame velocity (in a current: nu_r != nu)."""
    plant = Plant(bluerov, current=[0.3, -0.2, 0.1])
    q0 = bluerov.configuration(base=[0, 0, 0, 0.1, -0.05, 0.2], arm=[3.0, 1.8, 1.8, 1.0, 0.005])
    result = simulate(ActuatedPlant(plant, thrusters_of(bluerov)), sinusoids(bluerov.n_arm, 8), q0, 0.06, 0.01)
    model, data = plant.model, plant.model.createData()
    expected = []
    for q, v in zip(result.q, result.v):
        pin.forwardKinematics(model, data, q, v)
        total = 0.0
        for link in plant.links:
            pin.updateFramePlacement(model, data, link.frame_id)
            twist = pin.getFrameVelocity(model, data, link.frame_id, pin.LOCAL).vector
            relative = twist - np.concatenate([data.oMf[link.frame_id].rotation.T @ plant.current, np.zeros(3)])
            total += float(link.params.damping_wrench(relative) @ twist)
        expected.append(total)
    derived = damping_power(plant, result.q, result.v)  # (N,): every stored row at once
    assert derived.shape == (len(result.t),) and np.abs(derived).max() > 1e-3
    np.testing.assert_allclose(derived, expected, rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(result.actuation.damping_power, derived)
