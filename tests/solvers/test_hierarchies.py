"""Hierarchies of tasks (uvms.solvers.set_based, uvms.solvers.hqp, uvms.solvers.saturation): set-based task
priority (iCAT), the QP hierarchy, inequality objectives and priority-keeping saturation."""

from __future__ import annotations

import functools
from types import SimpleNamespace

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import uvms
from uvms.robot.configuration import Configuration
from uvms.robot.limits import Limit
from uvms.solvers import CLIKSolver, HQPSolver, SetBasedSolver, Solver, SolverResult, VariableDamping
from uvms.tasks import FrameTask, PostureTask
from uvms.tasks.objectives import (
    FrameBox,
    JointLimits,
    JointVelocityLimits,
    Manipulability,
    PlaneClearance,
    VehicleAttitude,
    VehicleVelocityLimits,
    bell,
    inequalities_from_table,
)

from conftest import SHIPPED, shipped

DT = 0.01
#: Vehicle entries weigh 100, arm joints 1: CLIK then reaches with the arm and drives a joint past its limit.
HEAVY_VEHICLE = np.r_[[100.0] * 6, [1.0] * 5]


@functools.lru_cache(maxsize=None)
def floating_ur5() -> uvms.Robot:
    """A fixed 6-DOF arm (UR5) on a passive floating base: a 6-axis task is not redundant."""
    return uvms.load(uvms.model.example_robot_urdf("ur5"), base="floating")


def violation(robot: uvms.Robot, q: np.ndarray, limit: Limit | None = None) -> float:
    """How far the arm is outside the position limits [rad or m] (0 inside)."""
    limit = Limit.joint_positions(robot) if limit is None else limit
    arm = robot.arm_configuration(q)
    return float(max(np.max(np.maximum(limit.lower - arm, arm - limit.upper)), 0.0))


def stepper(solver_class: type[Solver], robot, levels, dt, **options):
    """q -> (q+, the result) of one explicit-Euler step at dt of one solver built for the loop."""
    solver = solver_class(robot, levels, dt=dt, **options)

    def advance(q):
        configuration = Configuration(robot, q)
        velocity = solver.step(configuration, dt)
        return SimpleNamespace(q=configuration.q, velocity=velocity)
    return advance


def one_step(solver_class: type[Solver], robot, q, levels, dt, **options):
    """(q+, the result) of one step of a solver built for this call."""
    return stepper(solver_class, robot, levels, dt, **options)(q)


def solve_once(solver_class: type[Solver], robot, q, levels, **options) -> SolverResult:
    """The velocity at q of a solver built for this call."""
    return solver_class(robot, levels, **options).velocity(Configuration(robot, q))


def run(step, robot, q, levels, steps=500, **options):
    """Integrate ``steps`` steps; (last q, max limit violation, max speed ratio, task errors, results)."""
    worst, ratio, errors, results = 0.0, 0.0, [], []
    limit = options.pop("limit", None)
    advance = stepper(step, robot, levels, DT, **options)
    for _ in range(steps):
        result = advance(q)
        q = result.q
        worst = max(worst, violation(robot, q, limit))
        ratio = max(ratio, getattr(result.velocity, "speed_ratio", 0.0))
        errors.append(float(np.linalg.norm(result.velocity.error)))
        results.append(result.velocity)
    return q, worst, ratio, errors, results


def alpha5_reach():
    """BlueROV2 + Alpha 5 and a pose target that needs the elbow (axis c) at 3.9 rad, its limit being 3.5."""
    robot = shipped("bluerov2_alpha5")
    q0 = robot.configuration(base=[0, 0, -5, 0, 0, 0], arm=[3.0, 1.5, 3.2, 3.0, 0.007])
    target = robot.fk(robot.configuration(base=[0, 0, -5, 0, 0, 0], arm=[3.0, 1.5, 3.9, 3.0, 0.007]))
    return robot, q0, FrameTask(robot, target=target)


def ur5_reach():
    """UR5 on a passive vehicle, the elbow limited to 1.7 rad, and a target reached free floating at elbow 2.0."""
    robot = floating_ur5()
    arm0 = np.array([0.3, -1.2, 1.4, -1.5, -1.4, 0.2])
    q0 = robot.configuration(arm=arm0)
    q = q0.copy()
    rate = np.array([0.1, -0.2, 0.6, 0.2, 0.1, 0.1]) / 100
    for _ in range(100):  # the arm moves to arm0 + 100 rate and the vehicle follows momentum: a reachable pose
        q = pin.integrate(robot.model, q, robot.free_floating_velocity(q, rate))
    full = Limit.joint_positions(robot)
    upper = full.upper.copy()
    upper[2] = 1.7
    return robot, q0, FrameTask(robot, target=robot.fk(q)), Limit(full.lower, upper, full.names, full.q_index)


# ------------------------------------------------------------------------------------ objectives
def finite_difference(robot, objective, q, step=1e-6):
    jacobian = np.zeros((objective.dim, robot.nv))
    for index in range(robot.nv):
        tangent = np.zeros(robot.nv)
        tangent[index] = step
        ahead = objective.value(Configuration(robot, pin.integrate(robot.model, q, tangent)))
        behind = objective.value(Configuration(robot, pin.integrate(robot.model, q, -tangent)))
        jacobian[:, index] = (ahead - behind) / (2 * step)
    return jacobian


def test_objective_jacobians_are_the_derivatives_of_their_values(rng):
    robot = shipped("bluerov2_alpha5")
    objectives = [JointLimits(robot, band=0.2), VehicleAttitude(robot, 0.1),
                  PlaneClearance(robot, "vehicle", [0, 0, -5], [0, 0, 1], min=0.5),
                  PlaneClearance(robot, "ee", [1, 0, -5], [0.3, -0.2, 1], min=0.5), Manipulability(robot, min=0.01),
                  FrameBox(robot, lower=[-1, -1, -1], upper=[1, 1, 1])]
    for _ in range(3):
        q = robot.random_configuration(rng)
        for objective in objectives:
            error = np.abs(objective.jacobian(Configuration(robot, q)) - finite_difference(robot, objective, q)).max()
            assert error <= 1e-6, (objective, error)  # measured <= 4e-10


def test_activation_is_zero_inside_one_at_the_border_and_c1():
    band = np.array([0.2])
    assert bell(np.array([0.2 + 1e-9]), band)[0] == 0.0 and bell(np.array([0.0]), band)[0] == 1.0
    assert bell(np.array([0.1]), band)[0] == pytest.approx(0.5)
    h = 1e-7  # one-sided slopes at both ends of the band vanish (C1), the step shape jumps
    assert abs(bell(np.array([h]), band)[0] - 1.0) / h < 1e-5
    assert abs(bell(np.array([0.2 - h]), band)[0]) / h < 1e-5
    assert bell(np.array([0.2 - h]), band, "step")[0] == 1.0
    robot = shipped("bluerov2_alpha5")
    limits = JointLimits(robot, band=0.2, joints=["alpha_axis_c"])  # valid set [0, 3.5]
    assert limits.activation(np.array([1.7]))[0] == 0.0 and limits.activation(np.array([3.6]))[0] == 1.0
    assert limits.reference(np.array([3.45]))[0] == pytest.approx(1.0 * (3.3 - 3.45))  # back to the band's edge
    assert limits.reference(np.array([0.05]))[0] == pytest.approx(0.2 - 0.05)


# ---------------------------------------------------------------------------- CLIK special case
def inactive_cases():
    alpha5 = shipped("bluerov2_alpha5")
    q = alpha5.configuration(base=[0, 0, -5, 0.01, 0, 0], arm=[3.0, 1.5, 1.5, 3.0, 0.007])
    far = PlaneClearance(alpha5, "vehicle", [0, 0, -50], [0, 0, 1], min=1.0)
    yield alpha5, q, [JointLimits(alpha5, band=0.1), [VehicleAttitude(alpha5, 0.3), far]], {}
    yield alpha5, q, [JointLimits(alpha5, band=0.1)], {"weights": np.arange(1.0, 12.0)}
    yield alpha5, q, [JointLimits(alpha5, band=0.1)], {"damping": 0.05}
    yield alpha5, q, [JointLimits(alpha5, band=0.1)], {"damping": VariableDamping(2.0, 0.1)}
    yield alpha5, q, [JointLimits(alpha5, band=0.1)], {"free_floating": True, "damping": 0.02}
    hoang = shipped("hoang2011")
    yield hoang, hoang.configuration(base=[0, 0, 0], arm=[1.0, 0.5, 0.5]), [JointLimits(hoang, band=0.3)], \
        {"weights": np.array([1, 1, 1, 100, 100, 100.0])}


@pytest.mark.parametrize("case", range(6))
def test_with_every_inequality_inactive_set_based_is_clik(case):
    robot, q, above, options = list(inactive_cases())[case]
    offset = pin.SE3(pin.rpy.rpyToMatrix(0.05, 0, 0.1), np.array([0.1, 0.05, 0.02]))
    task = FrameTask(robot, target=robot.fk(q) * offset)
    result = solve_once(SetBasedSolver, robot, q, [*above, task], gain=2.0, **options)
    assert result.active == ()
    reference = solve_once(CLIKSolver, robot, q, task, gain=2.0, **options)
    assert np.abs(result.v - reference.v).max() <= 1e-12  # measured 0.0 (the same inverse, the same call)
    assert result.residual == pytest.approx(reference.residual, abs=1e-12)


def test_dual_arm_tasks_at_one_level_or_two_levels_keep_the_limits():
    robot = shipped("xiang2019")
    q = robot.configuration(base=[0, 0, -3, 0, 0, 0], arm=[-1.0, 0.2, 0.3, 0.1, 0.4, -1.0, 0.2, 0.3, 0.1, 0.4])
    left, right = (FrameTask(robot, frame, axes=("x", "y", "z"), target=pin.SE3(robot.fk(q, frame).rotation,
                   robot.fk(q, frame).translation + [0.05, 0, 0])) for frame in ("left_ee", "right_ee"))
    limits = JointLimits(robot, band=0.05)
    one = solve_once(SetBasedSolver, robot, q, [limits, [left, right]], free_floating=True)
    assert np.abs(one.v - solve_once(CLIKSolver, robot, q, [left, right], free_floating=True).v).max() <= 1e-12
    two = solve_once(SetBasedSolver, robot, q, [limits, left, right], free_floating=True)
    assert two.task_residuals[1] <= 1e-10  # the left arm's task, above the right one's
    _, clik_worst, *_ = run(CLIKSolver, robot, q, [left, right], steps=300, gain=2.0, free_floating=True)
    assert clik_worst > 0.5  # measured: a claw 1.05 past its limit
    for levels in ([limits, [left, right]], [limits, left, right]):
        _, worst, _, errors, _ = run(SetBasedSolver, robot, q, levels, steps=300, gain=2.0, free_floating=True)
        assert worst == 0.0 and errors[-1] <= 0.01  # measured 0.0040 (one level), 0.0066 (two)


# ------------------------------------------------------------------------ limits are never crossed
def test_redundant_uvms_never_crosses_a_limit_that_clik_crosses():
    robot, q0, task = alpha5_reach()
    _, clik_worst, *_ = run(CLIKSolver, robot, q0, task, gain=2.0, weights=HEAVY_VEHICLE)
    assert clik_worst > 0.2  # measured 0.237 rad past the elbow's 3.5 rad
    levels = [JointLimits(robot, margin={"alpha_axis_c": 0.05, "alpha_axis_d": 0.05}, band=0.2),
              JointVelocityLimits(robot), task]
    for step in (SetBasedSolver, HQPSolver):
        _, worst, ratio, errors, results = run(step, robot, q0, levels, gain=2.0, weights=HEAVY_VEHICLE)
        assert worst == 0.0 and ratio <= 1.0 + 1e-9  # positions and speeds (0.5 rad/s) kept at every step
        assert errors[-1] <= 1e-3  # measured 4.9e-5 (set_based), 3.0e-5 (hqp): the vehicle takes over
        assert any(r.status("joint_limits").active for r in results)


def test_non_redundant_free_floating_arm_the_limit_wins_and_the_error_is_reported():
    robot, q0, task, limit = ur5_reach()
    _, clik_worst, _, clik_errors, _ = run(CLIKSolver, robot, q0, task, gain=2.0, free_floating=True, limit=limit)
    assert clik_worst > 0.25 and clik_errors[-1] < 1e-3  # measured: the elbow 0.31 rad past 1.7 rad
    levels = [JointLimits(robot, margin=0.02, band=0.15, limit=limit), JointVelocityLimits(robot, 1.0), task]
    options = {"gain": 2.0, "free_floating": True, "limit": limit}
    for step, extra in ((SetBasedSolver, {"damping": VariableDamping(0.05, 0.05)}), (HQPSolver, {})):
        _, worst, ratio, errors, results = run(step, robot, q0, levels, **options, **extra)
        assert worst == 0.0 and ratio <= 1.0 + 1e-9
        assert errors[-1] > 0.03  # measured 0.057 (set_based), 0.044 (hqp): the task gives way
        assert results[-1].status("joint_limits").active


def test_hqp_started_outside_a_limit_comes_back_at_the_allowed_speed_and_is_never_infeasible():
    robot, _, task = alpha5_reach()
    q = robot.configuration(base=[0, 0, -5, 0, 0, 0], arm=[3.0, 1.5, 3.7, 3.0, 0.007])  # elbow 0.2 past 3.5
    limits = JointLimits(robot, margin=0.05, joints=["alpha_axis_c", "alpha_axis_d"])
    levels = [limits, JointVelocityLimits(robot), task]
    elbow = [3.7]
    for _ in range(60):
        result = one_step(HQPSolver, robot, q, levels, DT, gain=2.0, weights=HEAVY_VEHICLE)
        q = result.q
        elbow.append(robot.arm_configuration(q)[2])
        assert all(status.startswith("optimal") for status in result.velocity.extras["solver_status"])
    steps = -np.diff(elbow)
    assert np.allclose(steps[:40], 0.5 * DT, atol=1e-9)  # back at its 0.5 rad/s while outside (0.25 rad: 50 steps)
    assert max(elbow[-1] - 3.45, 0.0) <= 1e-9  # then inside the valid set
    q = robot.configuration(base=[0, 0, -5, 0, 0, 0], arm=[3.0, 1.5, 3.7, 3.0, 0.007])
    # set-based: back, never further
    back = one_step(SetBasedSolver, robot, q, levels, DT, gain=2.0, weights=HEAVY_VEHICLE)
    assert robot.arm_configuration(back.q)[2] < 3.7 and back.velocity.speed_ratio <= 1.0 + 1e-12


# ------------------------------------------------------------------------------- equality met
def test_an_equality_task_feasible_with_the_active_inequalities_is_met():
    robot = shipped("bluerov2_alpha5")
    q = robot.configuration(base=[0, 0, -5, 0.15, 0.0, 0.3], arm=[3.0, 1.5, 3.4, 3.0, 0.007])  # tilted, elbow in band
    levels = [JointLimits(robot, margin={"alpha_axis_c": 0.05}, band=0.2), VehicleAttitude(robot, 0.1),
              FrameTask(robot, target=robot.fk(q) * pin.SE3(np.eye(3), np.array([0.1, 0.0, 0.05])))]
    result = solve_once(SetBasedSolver, robot, q, levels, gain=1.0)
    assert set(result.active) == {"joint_limits", "vehicle_attitude"}
    assert result.residual <= 1e-9  # measured ~1e-15: 6 task rows in the 9 DOF the inequalities leave
    assert result.task_residuals[1] <= 1e-12  # the tilt, fully active, comes back at its reference rate
    hqp = solve_once(HQPSolver, robot, q, levels, dt=DT, gain=1.0)
    assert hqp.residual <= 1e-7 and hqp.status("vehicle_attitude").active  # measured ~1e-10



def test_a_results_activity_is_its_objectives_active_flags():
    """SolverResult.activity (what a recorder reads at every row) names each objective with its statuses' ``active``:
    set-based from the activations (two active, one not), the QP hierarchy from its binding rows."""
    robot = shipped("bluerov2_alpha5")
    q = robot.configuration(base=[0, 0, -5, 0.15, 0.0, 0.3], arm=[3.0, 1.5, 3.4, 3.0, 0.007])  # tilted, elbow in band
    clearance = PlaneClearance(robot, "vehicle", [0.0, 0.0, -9.0], [0.0, 0.0, 1.0], min=0.5, band=0.1)  # far: idle
    levels = [JointLimits(robot, margin={"alpha_axis_c": 0.05}, band=0.2), VehicleAttitude(robot, 0.1), clearance,
              FrameTask(robot, target=robot.fk(q) * pin.SE3(np.eye(3), np.array([0.1, 0.0, 0.05])))]
    set_based = solve_once(SetBasedSolver, robot, q, levels, gain=1.0)
    assert set_based.activity == {"joint_limits": True, "vehicle_attitude": True, clearance.name: False}
    assert list(set_based.activity.items()) == [(status.name, status.active) for status in set_based.objectives]
    hqp = solve_once(HQPSolver, robot, q, levels, dt=DT, gain=1.0)
    assert hqp.activity == {status.name: status.active for status in hqp.objectives}
    assert hqp.activity["vehicle_attitude"] and not hqp.activity[clearance.name]


# ------------------------------------------------------------------------------------ continuity
def max_velocity_jump(shape: str, dt: float) -> tuple[float, float]:
    """(max |v_{k+1} - v_k| over a reach that activates the elbow's limit, its activation after the run)."""
    robot, q, task = alpha5_reach()
    levels = [JointLimits(robot, margin={"alpha_axis_c": 0.05}, band=0.2, shape=shape, joints=["alpha_axis_c"]), task]
    velocities = []
    advance = stepper(SetBasedSolver, robot, levels, dt, weights=HEAVY_VEHICLE)
    for _ in range(int(round(2.0 / dt))):
        result = advance(q)
        q = result.q
        velocities.append(result.velocity.v)
    jumps = np.abs(np.diff(velocities, axis=0)).max()
    return float(jumps), float(result.velocity.status("joint_limits").activation[0])


def test_activation_changes_the_velocity_by_o_dt_where_a_hard_switch_jumps():
    smooth, activation = max_velocity_jump("cosine", DT)
    smooth_half, _ = max_velocity_jump("cosine", DT / 2)
    hard, _ = max_velocity_jump("step", DT)
    hard_half, _ = max_velocity_jump("step", DT / 2)
    assert 0.0 < activation < 1.0  # the run ends inside the band
    assert smooth_half / smooth == pytest.approx(0.5, abs=0.1)  # O(dt): measured 0.0171 -> 0.0085 rad/s
    assert hard > 20 * smooth and hard_half == pytest.approx(hard, rel=0.05)  # measured 0.577 at both steps


# ----------------------------------------------------------------------------- saturation
def test_saturation_scales_the_lowest_level_first_and_keeps_the_higher_ones():
    robot = shipped("bluerov2_alpha5")
    q = robot.configuration(base=[0, 0, -5, 0, 0, 0], arm=[3.0, 1.5, 1.5, 3.0, 0.007])
    reach = FrameTask(robot, axes=("x", "y", "z"), target=robot.fk(q) * pin.SE3(np.eye(3), np.array([0.05, 0, 0])))
    posture = PostureTask(robot, robot.configuration(base=[0, 0, -5, 0, 0, 0], arm=[4.0, 2.5, 2.5, 4.0, 0.01]))
    limits = [JointVelocityLimits(robot, 0.2), VehicleVelocityLimits(robot, [0.3, 0.3])]
    result = solve_once(SetBasedSolver, robot, q, [reach, posture, *limits], gain=2.0)
    assert result.scales[0] == 1.0 and 0.0 < result.scales[1] < 1.0  # measured 0.1
    assert result.task_residuals[0] <= 1e-12 and result.speed_ratio == pytest.approx(1.0)
    hqp = solve_once(HQPSolver, robot, q, [reach, posture, *limits], dt=DT, gain=2.0)
    assert hqp.task_residuals[0] <= 1e-7 and hqp.speed_ratio <= 1.0 + 1e-9
    contributions = [np.array([0.5, 0.0]), np.array([1.0, 1.0])]
    from uvms.numerics._kernels.boxes import scale_lowest_first_into

    total, scales = np.empty(2), np.empty(2)
    scale_lowest_first_into(np.array(contributions), -np.ones(2), np.ones(2), 1e-12, total, scales)
    assert scales.tolist() == [1.0, 0.5] and np.allclose(total, [1.0, 0.5])


def test_a_passive_vehicles_speed_limits_hold_through_momentum_conservation():
    robot = shipped("amundsen2018")  # a swimming manipulator: its base link weighs what a link does
    q = robot.random_configuration(3)
    task = FrameTask(robot, axes=("x", "y", "z"), target=pin.SE3(np.eye(3), robot.fk(q).translation + [0.3, -0.2, 0.2]))
    free = solve_once(SetBasedSolver, robot, q, [task], gain=2.0, free_floating=True)
    assert np.abs(free.v[3]) > 2.0  # measured: the reaction turns the vehicle at 2.86 rad/s
    limits = VehicleVelocityLimits(robot, [0.05, 0.1])  # [m/s, rad/s]
    maximum = np.array([0.05] * 3 + [0.1] * 3)
    for solver_class in (SetBasedSolver, HQPSolver):
        result = solve_once(solver_class, robot, q, [JointLimits(robot, band=0.05), task, limits], gain=2.0,
                            free_floating=True, dt=DT)
        assert np.all(np.abs(result.v[:6]) <= maximum * (1 + 1e-7))  # hqp: rows kept to the QP tolerance
        assert result.speed_ratio == pytest.approx(1.0, abs=1e-7)


# ------------------------------------------------------------------------------------ hypothesis
def outside_distance(robot: uvms.Robot, q: np.ndarray, limit: Limit) -> np.ndarray:
    """Per arm coordinate, how far it is outside its limits (n_arm,) (0 inside)."""
    arm = robot.arm_configuration(q)
    return np.maximum(np.maximum(limit.lower - arm, arm - limit.upper), 0.0)


@settings(max_examples=50, deadline=None)
@given(name=st.sampled_from(SHIPPED), seed=st.integers(0, 2**31 - 1), free=st.booleans(), outside=st.booleans())
def test_random_models_and_configurations_give_finite_velocities_inside_the_bounds(name, seed, free, outside):
    robot = shipped(name)
    rng = np.random.default_rng(seed)
    q = robot.random_configuration(rng)
    limit = Limit.joint_positions(robot)
    if outside:  # some joints up to 0.3 past their limits: nothing may push them further out
        arm = robot.arm_configuration(q) + rng.choice([-1, 0, 1], robot.n_arm) * rng.uniform(0, 0.3, robot.n_arm)
        q = robot.configuration(base=robot.base_values(q) if robot.n_vehicle else None,
                                arm=np.where(limit.bounded, np.clip(arm, limit.lower - 0.3, limit.upper + 0.3), arm))
    levels = [JointLimits(robot, band=0.05), JointVelocityLimits(robot, 0.3), FrameTask(robot, target=robot.fk(
        robot.random_configuration(rng)))]
    if robot.base_type == "floating":
        seabed = PlaneClearance(robot, "vehicle", [0, 0, -3], [0, 0, 1], min=0.5)
        levels.insert(1, [VehicleAttitude(robot, 0.2), seabed])
    before = outside_distance(robot, q, limit)
    for solver_class, options in ((SetBasedSolver, {"damping": 0.05}), (HQPSolver, {})):
        result = solve_once(solver_class, robot, q, levels, dt=DT, free_floating=free, **options)
        assert np.all(np.isfinite(result.v))
        assert np.all(np.abs(result.v[robot.n_vehicle:]) <= 0.3 + 1e-9)
        after = outside_distance(robot, pin.integrate(robot.model, q, result.v * DT), limit)
        assert np.all(after <= before + 1e-9) and (outside or after.max() <= 1e-9)
        assert all(status.startswith("optimal") for status in result.extras.get("solver_status", ()))


# ---------------------------------------------------------------------------------- bad input
def test_names_and_parameters_are_checked_with_the_valid_ones():
    robot = shipped("bluerov2_alpha5")
    with pytest.raises(uvms.UVMSError, match="close names: joint_limits"):
        inequalities_from_table(robot, {"type": "joint_limit"})
    with pytest.raises(uvms.UVMSError, match="close names: margin"):
        inequalities_from_table(robot, {"type": "joint_limits", "margn": 0.1})
    with pytest.raises(uvms.UVMSError, match="close names: vehicle"):
        PlaneClearance(robot, "vehicl", [0, 0, 0], [0, 0, 1])
    with pytest.raises(uvms.UVMSError, match="alpha_axis_a"):
        JointLimits(robot, margin=0.05)  # the 0.015 m jaw has no room for 0.05
    with pytest.raises(uvms.UVMSError, match="non-zero"):
        PlaneClearance(robot, "ee", [0, 0, 0], [0, 0, 0])
    with pytest.raises(uvms.UVMSError, match="planar vehicle cannot tilt"):
        VehicleAttitude(shipped("hoang2011"), 0.1)
    with pytest.raises(uvms.UVMSError, match="close names: vx"):
        VehicleVelocityLimits(robot, {"vxx": 0.3})
    indefinite = np.diag(np.r_[1.0, -1.0, np.ones(robot.nv - 2)])  # symmetric, one negative eigenvalue
    with pytest.raises(uvms.UVMSError, match="positive definite"):
        HQPSolver(robot, [FrameTask(robot)], dt=DT, weights=indefinite + 1e-3 * np.eye(robot.nv)[::-1])
    built = inequalities_from_table(robot, {"type": "joint_velocity", "max": 0.3, "vehicle_max": [0.5, 0.2]})
    assert [type(item).__name__ for item in built] == ["JointVelocityLimits", "VehicleVelocityLimits"]
    assert built[1].maximum[:6].tolist() == [0.5, 0.5, 0.5, 0.2, 0.2, 0.2]


def weighted_damped_inverse_reference(matrix: np.ndarray, weights: np.ndarray, damping: float,
                                      floor: float = 0.0) -> np.ndarray:
    """L^-T V diag(s / (s^2 + l^2)) U^T of Z L^-T = U S V^T, W = L L^T, from LAPACK's SVD (other numbers than the
    compiled Jacobi SVD's): singular values at or below ``floor`` and, undamped, below 1e-12 s_max dropped."""
    factor_t_inv = np.linalg.inv(np.linalg.cholesky(weights)).T  # L^-T
    u, s, vt = np.linalg.svd(matrix @ factor_t_inv, full_matrices=False)
    keep = s > max(floor, 0.0 if damping > 0 else 1e-12 * s.max(initial=0.0))
    return factor_t_inv @ (vt[keep].T * (s[keep] / (s[keep] ** 2 + damping**2))) @ u[:, keep].T


def icat_reference(levels: list, weights: np.ndarray, damping: float, eta: float) -> np.ndarray:
    """Simetti and Casalino (2016) eqs. 18-20 in numpy: rho_k - rho_{k-1} of each level (L, n).

    rho_k = rho_{k-1} + Q (J Q)^{#,A,I} W_k (xdot - J rho_{k-1}), W_k = J Q (J Q)^{#,A,Q},
    Q_k = Q (I - (J Q)^{#,A,I} J Q), X^{#,A,Q} = (X^T A X + eta (I - Q)^T D^2 (I - Q))^# X^T A A (D = diag of the column
    norms of A^1/2 J), the damping in X^{#,A,I} only; a level of activations 1 while Q = I is plain CLIK. Below the
    first level, singular values of X = J Q under 1e-12 of |A^1/2 J L^-T|_F count as zero: the rounding Q keeps of the
    levels above.
    """
    size = weights.shape[0]
    rho, projector, unrestricted = np.zeros(size), np.eye(size), True
    contributions = []
    for jacobian, reference, activation, equality in levels:
        if not equality and not (activation > 0).any():
            contributions.append(np.zeros(size))
            continue
        remaining = reference - jacobian @ rho
        if unrestricted and (equality or (activation == 1).all()):
            inverse = weighted_damped_inverse_reference(jacobian, weights, damping)
            contribution = inverse @ remaining
            projector = projector - inverse @ jacobian
        else:
            active = activation > 0
            a = activation[active]
            projected = jacobian[active] @ projector
            rows = np.sqrt(a)[:, None] * projected
            factor_t_inv = np.linalg.inv(np.linalg.cholesky(weights)).T
            unprojected = np.sqrt(a)[:, None] * jacobian[active] @ factor_t_inv
            floor = 0.0 if unrestricted else 1e-12 * np.linalg.norm(unprojected)
            inverse = weighted_damped_inverse_reference(rows, weights, damping, floor) * a**1.5
            if not unrestricted and eta > 0:
                column_norms = np.linalg.norm(np.sqrt(a)[:, None] * jacobian[active], axis=0)
                rows = np.vstack([rows, np.sqrt(eta) * column_norms[:, None] * (np.eye(size) - projector)])
            regularized = weighted_damped_inverse_reference(rows, weights, 0.0, floor)[:, : a.size] * a**1.5
            contribution = projector @ inverse @ (projected @ regularized) @ remaining[active]
            projector = projector - projector @ inverse @ projected
        rho = rho + contribution
        unrestricted = False
        contributions.append(contribution)
    return np.array(contributions)


@pytest.mark.parametrize("weighting", ["identity", "diagonal", "full"])
@pytest.mark.parametrize("damping", [0.0, 0.05])
@pytest.mark.parametrize("eta", [0.0, 0.01])
def test_the_compiled_icat_recursion_is_the_papers_formulas(rng, weighting, damping, eta):
    """The one compiled iCAT call (``_kernels.icat.icat_into``) against the paper's formulas in numpy, over levels with
    partial, zero and unit activations, an equality level, and the plain-CLIK first level."""
    from uvms.numerics._kernels.icat import icat_into
    from uvms.numerics.inverses import RCOND, WeightedInverse

    size = 6  # fewer columns than active rows: the eta term changes the answer
    weights_given = {"identity": None, "diagonal": rng.uniform(0.5, 3.0, size),
                     "full": (lambda m: m @ m.T + size * np.eye(size))(rng.normal(size=(size, size)))}[weighting]
    weights = np.eye(size) if weights_given is None else np.diag(weights_given) if weights_given.ndim == 1 \
        else weights_given
    kernel_weights = WeightedInverse(weights_given, size).kernel_weights
    for first_is_clik in (False, True):
        activations = [np.array([0.0, 0.4, 1.0]), np.ones(3), np.array([0.7, 0.2, 0.5]), np.zeros(2)]
        if first_is_clik:
            activations[0] = np.ones(3)
        equality = np.array([False, True, False, False])
        jacobians = [rng.normal(size=(a.size, size)) for a in activations]
        references = [rng.normal(size=a.size) for a in activations]
        levels = list(zip(jacobians, references, activations, equality))
        offsets = np.cumsum([0] + [a.size for a in activations]).astype(np.int64)
        contributions, sigmas = np.empty((4, size)), np.empty(4)
        converged, _ = icat_into(np.concatenate(jacobians), np.concatenate(references), np.concatenate(activations),
                                 offsets, equality, *kernel_weights, damping, 0.0, 0.0, RCOND, eta, contributions,
                                 sigmas)
        expected = icat_reference(levels, weights, damping, eta)
        assert converged
        assert np.abs(contributions - expected).max() <= 1e-9 * max(1.0, np.abs(expected).max())
        assert np.abs(expected[1]).max() > 1e-3 and np.all(contributions[3] == 0.0)  # a level moved; the idle one not
        if eta > 0 and not first_is_clik:  # the test sees the eta term: without it the numbers differ
            assert np.abs(icat_reference(levels, weights, damping, 0.0) - expected).max() > 1e-6
        if first_is_clik and damping == 0:  # the two levels above take all six directions: nothing is left
            assert np.abs(contributions[2]).max() <= 1e-9


def test_icat_inverse_is_the_papers_regularized_inverse(rng):
    """The iCAT's one-level inverse (ICAT.level_inverse, the same compiled inverse as the recursion) against
    (X^T A X + eta (I - Q)^T D^2 (I - Q) + l^2 W)^-1 X^T A A, X = J Q, D = diag of the column norms of A^1/2 J."""
    from uvms.solvers.set_based import ICAT

    def icat_inverse(jacobian, activation, projector, weights, damping, eta):
        icat = ICAT(jacobian.shape[1], weights, damping, eta)
        return icat.level_inverse(jacobian, np.sqrt(activation)[:, None], activation**1.5, projector, icat.damping)

    size = 7
    jacobian, activation = rng.normal(size=(3, size)), np.array([0.3, 1.0, 0.6])
    basis = np.linalg.qr(rng.normal(size=(size, 2)))[0]
    projector = np.eye(size) - basis @ basis.T  # Q of a level above of rank 2
    weights = rng.uniform(0.5, 2.0, size)
    for damping, eta in ((0.0, 0.1), (0.05, 0.1), (0.05, 0.0)):
        inverse, _, used = icat_inverse(jacobian, activation, projector, weights, damping, eta)
        rows = np.sqrt(activation)[:, None] * jacobian @ projector
        if eta > 0:
            column_norms = np.linalg.norm(np.sqrt(activation)[:, None] * jacobian, axis=0)
            rows = np.vstack([rows, np.sqrt(eta) * column_norms[:, None] * (np.eye(size) - projector)])
        expected = weighted_damped_inverse_reference(rows, np.diag(weights), damping)[:, :3] * activation**1.5
        assert used == damping and np.abs(inverse - expected).max() <= 1e-10 * np.abs(expected).max()
