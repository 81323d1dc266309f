"""A fin's lift and drag against the equations of the plugins' sources, written out here at a few speeds and angles:
uuv_simulator's FinPlugin.cc + LiftDragModel.cc (Quadratic, TwoLines) and Gazebo Sim's LiftDrag.cc."""

import math

import numpy as np
import pytest

from uvms.dynamics.thrusters.lift_drag import (
    GzLiftDrag,
    UUVQuadratic,
    UUVTwoLines,
    gz_wrench,
    uuv_force,
)

SPEEDS = (0.5, 1.0, 2.0)  # [m/s]


@pytest.mark.parametrize("speed", SPEEDS)
@pytest.mark.parametrize("angle", (-0.3, 0.1, 0.4))
def test_uuv_quadratic_lift_is_the_angle_times_the_speed_squared(speed, angle):
    """LiftDragQuadratic::compute: lift = C_L a u^2 along -(z x v)/|v|, drag = C_D a^2 u^2 along -v/|v|, with a the
    angle of the velocity in the fin's x-y plane."""
    model = UUVQuadratic(lift_constant=20.0, drag_constant=9.0)
    velocity = speed * np.array([math.cos(angle), math.sin(angle), 0.3])  # the span (z) part is dropped
    lift, drag = 20.0 * angle * speed**2, 9.0 * angle**2 * speed**2
    expected = lift * np.array([math.sin(angle), -math.cos(angle), 0.0]) - drag * np.array([math.cos(angle),
                                                                                              math.sin(angle), 0.0])
    np.testing.assert_allclose(uuv_force(model, velocity), expected, rtol=1e-12, atol=1e-12)


def test_uuv_quadratic_folds_a_backward_flow_but_keeps_its_directions():
    """A fin moving backward: the angle is folded into [-pi/2, pi/2] (atan2 - pi), the directions are those of the
    unfolded velocity, as the source writes them."""
    model = UUVQuadratic(lift_constant=20.0, drag_constant=9.0)
    velocity = np.array([-1.0, 0.1, 0.0])  # atan2 = pi - 0.0997 -> folded -0.0997
    angle = math.atan2(0.1, -1.0) - math.pi
    u2 = 1.01
    lift_direction = -np.array([-0.1, -1.0, 0.0]) / math.sqrt(u2)  # -(z x v)/|v| = -(-v_y, v_x, 0)/|v|
    expected = 20.0 * angle * u2 * lift_direction + 9.0 * angle**2 * u2 * (-velocity / math.sqrt(u2))
    np.testing.assert_allclose(uuv_force(model, velocity), expected, rtol=1e-12)
    assert np.all(uuv_force(model, np.zeros(3)) == 0.0)  # no flow, no force (and no NaN)


@pytest.mark.parametrize("speed", SPEEDS)
def test_uuv_two_lines_below_and_beyond_the_stall(speed):
    """LiftDragTwoLines::compute: cl = cla alpha, cd = cda alpha below the stall; beyond, the stall slopes; on the
    negative side the source takes cda_stall for the lift too, and the drag of a negative alpha is negative."""
    model = UUVTwoLines(area=0.02, fluid_density=1000.0, a0=0.0, alpha_stall=0.3, cla=3.0, cla_stall=-1.0, cda=0.5,
                        cda_stall=2.0)
    q_area = 0.5 * 1000.0 * speed**2 * 0.02
    for alpha, cl, cd in ((0.2, 3.0 * 0.2, 0.5 * 0.2),
                          (0.5, 3.0 * 0.3 - 1.0 * 0.2, 0.5 * 0.3 + 2.0 * 0.2),
                          (-0.5, -3.0 * 0.3 + 2.0 * -0.2, -0.5 * 0.3 + 2.0 * -0.2)):
        direction = np.array([math.cos(alpha), math.sin(alpha), 0.0])
        expected = cl * q_area * np.array([direction[1], -direction[0], 0.0]) - cd * q_area * direction
        np.testing.assert_allclose(uuv_force(model, speed * direction), expected, rtol=1e-12, atol=1e-15)


def gz_oracle(speed, gamma, delta, model):
    """Gazebo Sim's LiftDrag for forward x, upward z, the velocity u (cos g, 0, sin g) in the x-z plane (no sweep):
    alpha = -g, lift along (-sin g, 0, cos g), drag along -v; with a control joint cl += k delta."""
    alpha = -gamma
    q_area = 0.5 * model.rho * speed**2 * model.area
    cl = model.cla * alpha + (model.control_joint_rad_to_cl * delta if model.control_joint else 0.0)
    cd = abs(model.cda * alpha)
    return q_area * (cl * np.array([-math.sin(gamma), 0.0, math.cos(gamma)])
                     - cd * np.array([math.cos(gamma), 0.0, math.sin(gamma)]))


@pytest.mark.parametrize("speed", SPEEDS)
@pytest.mark.parametrize("gamma", (-0.1, 0.05))
@pytest.mark.parametrize("delta", (0.0, 0.2))
def test_gz_lift_drag_below_the_stall(speed, gamma, delta):
    model = GzLiftDrag(cla=4.13, cda=0.2, alpha_stall=0.3, rho=1000.0, area=0.0244, control_joint=True,
                       control_joint_rad_to_cl=2.0)
    velocity = speed * np.array([math.cos(gamma), 0.0, math.sin(gamma)])
    force, torque = gz_wrench(model, np.eye(3), velocity, np.zeros(3), delta)
    np.testing.assert_allclose(force, gz_oracle(speed, gamma, delta, model), rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(torque, 0.0, atol=1e-14)  # cm = 0, cp at the origin


def test_gz_lift_drag_stall_moment_and_the_cases_without_force():
    model = GzLiftDrag(cla=4.0, cla_stall=-1.0, cda=0.2, cda_stall=1.0, cma=0.5, alpha_stall=0.2, rho=1000.0,
                       area=0.1, cp=(0.1, 0.0, 0.0))
    gamma = -0.3  # alpha = 0.3 > stall: cl = 4 * 0.2 - 1 * 0.1 = 0.7 (kept >= 0), cd = 0.2 * 0.2 + 1 * 0.1 = 0.14
    velocity = np.array([math.cos(gamma), 0.0, math.sin(gamma)])
    force, torque = gz_wrench(model, np.eye(3), velocity, np.zeros(3), 0.0)
    q_area = 0.5 * 1000.0 * 0.1
    expected = q_area * (0.7 * np.array([-math.sin(gamma), 0.0, math.cos(gamma)]) - 0.14 * velocity)
    np.testing.assert_allclose(force, expected, rtol=1e-12)
    cm = max(0.0, 0.5 * 0.2)  # cma_stall 0: cm = cma alpha_stall beyond the stall
    moment = cm * q_area * np.array([0.0, -1.0, 0.0])  # along the spanwise x cross z = -y
    np.testing.assert_allclose(torque, moment + np.cross([0.1, 0.0, 0.0], force), rtol=1e-12, atol=1e-12)
    # no force below 0.01 m/s, nor when moving backward (not reversible)
    assert not np.any(gz_wrench(model, np.eye(3), np.array([0.009, 0.0, 0.0]), np.zeros(3), 0.0)[0])
    assert not np.any(gz_wrench(model, np.eye(3), np.array([-1.0, 0.0, 0.1]), np.zeros(3), 0.0)[0])
    # the angular velocity moves the centre of pressure: w x cp adds to the velocity there
    spun = gz_wrench(model, np.eye(3), np.array([1.0, 0.0, -0.1]), np.array([0.0, 1.0, 0.0]), 0.0)[0]
    np.testing.assert_allclose(spun, gz_wrench(model, np.eye(3), np.array([1.0, 0.0, -0.2]), np.zeros(3), 0.0)[0])
