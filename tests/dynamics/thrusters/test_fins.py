"""Fins as model data (uvms.dynamics.thrusters.fins): read from uuv_simulator's fin plugin and Gazebo Sim's LiftDrag,
their wrench on the vehicle at an angle, and the actuated plant turning them with their time constant."""

import math
from pathlib import Path

import numpy as np
import pytest

import uvms
from uvms.control import OpenLoop
from uvms.dynamics import Plant
from uvms.dynamics.hydro.hydrodynamics import hydrodynamics_of
from uvms.dynamics.plant.actuated import ActuatedPlant
from uvms.dynamics.thrusters.fins import DEFAULT_TIME_CONSTANT, fins_of
from uvms.dynamics.thrusters.thrusters import thrusters_of
from uvms.errors import (
    BaseGuessWarning,
    FinDefaultWarning,
    ModelCheckError,
    PointMassWarning,
)
from uvms.sim.loop import simulate

AUV = Path(__file__).parents[2] / "fixtures" / "auv"
TORPEDO = AUV / "torpedo.urdf"
LRAUV = AUV / "gz_lrauv" / "lrauv_like.urdf"


def load_torpedo(path: Path = TORPEDO, **options) -> uvms.Robot:
    """The torpedo as uuv_simulator writes it: point-mass fin and propeller links, no world link (both warned)."""
    with pytest.warns(PointMassWarning), pytest.warns(BaseGuessWarning):
        return uvms.load(path, **options)


@pytest.fixture(scope="module")
def torpedo():
    return load_torpedo()


def test_the_torpedo_loads_with_its_fins_frozen_as_control_surfaces(torpedo):
    """Before: refused ("the mass matrix is singular ... point-mass link(s) torpedo/fin0"): the fins were arm joints.
    Now each fin joint is class ``fin`` with the plugin that makes it one, held at 0, its written limits kept."""
    assert torpedo.n_arm == 0 and torpedo.nv == 6
    fins = {name: c for name, c in torpedo.joint_classes.items() if c.kind == "fin"}
    assert list(fins) == [f"torpedo/fin{i}_joint" for i in range(4)]
    assert fins["torpedo/fin0_joint"].reason == ("uuv_simulator fin plugin 'torpedo_fin0_model' names it "
                                                 "(<joint_name>); held at 0")
    assert all(c.value == 0.0 and c.limits == (-0.4, 0.4) for c in fins.values())
    data = fins_of(torpedo)
    assert data.names == [f"torpedo_fin{i}_model" for i in range(4)]
    np.testing.assert_array_equal(data.time_constants, 0.2)
    np.testing.assert_array_equal(data.upper, 0.4)
    np.testing.assert_allclose([fin.position for fin in data.items],
                               [[-0.75, -0.12, 0.0], [-0.75, 0.0, 0.12], [-0.75, 0.12, 0.0], [-0.75, 0.0, -0.12]],
                               atol=1e-12)


@pytest.mark.parametrize("speed", (0.5, 1.0, 2.0))
@pytest.mark.parametrize("delta", (-0.3, 0.1, 0.4))
def test_a_uuv_fin_turned_by_delta_gives_its_plugin_lift_and_drag(torpedo, speed, delta):
    """The top rudder (span +z) turned by delta at a surge u: the flow meets it at -delta, so in the base frame the
    Quadratic model gives lift C_L delta u^2 along +y and drag C_D delta^2 u^2 along -x, at x = -0.75, z = 0.12."""
    rudder = fins_of(torpedo).items[1]
    wrench = rudder.wrench(np.array([speed, 0.0, 0.0, 0.0, 0.0, 0.0]), np.zeros(3), delta)
    force = np.array([-9.0 * delta**2 * speed**2, 20.0 * delta * speed**2, 0.0])
    np.testing.assert_allclose(wrench[:3], force, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(wrench[3:], np.cross([-0.75, 0.0, 0.12], force), rtol=1e-12, atol=1e-12)
    # the water's velocity counts (uuv's fin plugin subtracts the current): a current of the vehicle's own speed
    np.testing.assert_allclose(rudder.wrench(np.array([speed, 0, 0, 0, 0, 0.0]), np.array([speed, 0, 0]), delta), 0.0)


@pytest.fixture(scope="module")
def lrauv():
    return uvms.load(LRAUV)


def test_gz_lift_drag_fins_turn_with_their_joint_and_by_the_control_joint(lrauv):
    """The horizontal fin (no control joint: its link turns about y) meets the flow at alpha = -delta: lift
    -cla delta q A along +z; the vertical fin (its link turns about z and <control_joint_name> adds 2/rad to cl):
    (cla + 2) delta q A along +y; drag |cda delta| q A backward; a LiftDrag on the hull is a fixed surface."""
    with pytest.warns(FinDefaultWarning, match="horizontal_fins, vertical_fins take uvms's default time constant"):
        fins = fins_of(lrauv)
    assert fins.names == ["horizontal_fins", "vertical_fins", "base_link"]
    assert [lrauv.joint_classes[name].kind for name in ("horizontal_fins_joint", "vertical_fins_joint")] == ["fin"] * 2
    horizontal, vertical, hull = fins.items
    assert horizontal.time_constant == vertical.time_constant == DEFAULT_TIME_CONSTANT
    assert hull.joint is None and not hull.moves and vertical.allocation_bounds == (-0.17, 0.17)
    for speed in (0.5, 1.0, 2.0):
        twist = np.array([speed, 0.0, 0.0, 0.0, 0.0, 0.0])
        q_area = 0.5 * 1000.0 * speed**2 * 0.0244
        for delta in (-0.1, 0.15):
            drag = -abs(0.2 * delta) * q_area
            lift = horizontal.wrench(twist, np.zeros(3), delta)
            np.testing.assert_allclose(lift[:3], [drag, 0.0, -4.13 * delta * q_area], rtol=1e-12, atol=1e-12)
            np.testing.assert_allclose(lift[4], 0.6 * lift[2], rtol=1e-12)  # at x = -0.6: pitch = -x F_z
            side = vertical.wrench(twist, np.zeros(3), delta)
            cp_drag = -abs(0.2 * delta) * q_area
            np.testing.assert_allclose(side[:3], [cp_drag, (4.13 + 2.0) * delta * q_area, 0.0], rtol=1e-12,
                                       atol=1e-12)
        # gz subtracts no ocean current: a current changes nothing
        np.testing.assert_array_equal(horizontal.wrench(twist, np.array([speed, 0, 0]), 0.1),
                                      horizontal.wrench(twist, np.zeros(3), 0.1))


def test_fin_plugins_with_wrong_data_are_refused_with_what_is_valid(tmp_path):
    text = TORPEDO.read_text()
    cases = {"<type>Quadratic</type>": ("<type>TwoLinesWithSlope</type>", "valid: Quadratic, TwoLines"),
             "<lift_constant>20.0</lift_constant>": ("", "<lift_constant> is missing"),
             '<limit effort="0" lower="-0.4" upper="0.4"': ('<limit effort="0" lower="0.1" upper="0.4"',
                                                            "exclude 0")}
    for index, (old, (new, message)) in enumerate(cases.items()):
        path = tmp_path / f"bad{index}.urdf"
        path.write_text(text.replace(old, new, 1))
        with pytest.raises(ModelCheckError, match=message):
            fins_of(load_torpedo(path))


def test_a_fin_joint_named_in_arm_joints_moves_and_its_plugin_is_left_out():
    robot = uvms.load(LRAUV, arm_joints=["horizontal_fins_joint"])
    assert robot.n_arm == 1 and robot.joint_classes["horizontal_fins_joint"].kind == "arm"
    assert robot.joint_classes["vertical_fins_joint"].kind == "fin"
    with pytest.warns(FinDefaultWarning) as caught:
        assert fins_of(robot).names == ["vertical_fins", "base_link"]
    assert "'horizontal_fins_joint' moves as an arm joint (arm_joints names it)" in str(caught[0].message)


def test_the_actuated_plant_turns_each_fin_with_its_time_constant_and_applies_its_wrench(torpedo):
    """A held command of 0.6 rad is clipped to the 0.4 limit; after one time constant (0.2 s) the angle is
    0.4 (1 - 1/e); the body wrench the plant records is the thrust plus the fins' lift and drag at the state."""
    plant = Plant(torpedo, hydrodynamics_of(torpedo), gravity=True)
    fins = fins_of(torpedo)
    actuated = ActuatedPlant(plant, thrusters_of(torpedo), fins=fins)

    command = OpenLoop(arm=np.zeros(0), thrust=np.array([7.3]), fins=np.array([0.6, 0.0, -0.1, 0.0]))

    v0 = np.array([1.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    result = simulate(actuated, command, torpedo.neutral(), 0.2, 0.002, v0=v0)
    angles = result.actuation.controller["fin_angles"]
    np.testing.assert_allclose(angles[-1], [0.4 * (1 - math.exp(-1)), 0.0, -0.1 * (1 - math.exp(-1)), 0.0],
                               rtol=1e-6)
    np.testing.assert_array_equal(result.actuation.controller["fin_command"][-1], [0.4, 0.0, -0.1, 0.0])
    k = len(result.t) // 2
    nu = result.v[k]
    expected = fins.wrench(nu, np.zeros(3), angles[k])
    np.testing.assert_allclose(result.actuation.controller["fin_wrench"][k], expected, rtol=1e-12)
    np.testing.assert_allclose(result.actuation.body_wrench[k], expected + [result.actuation.thrusts[k, 0], 0, 0, 0,
                                                                            0, 0], rtol=1e-12)
    assert expected[2] > 0.5  # elevators 0 (+0.25 rad) and 2 (-0.06 rad) both lift the tail at about 1 m/s
