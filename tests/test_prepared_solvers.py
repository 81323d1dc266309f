"""The prepared control core: a CLIKSolver built once gives clik_velocity's numbers bit for bit, every call.

The speed work (issue 16) keeps every shipped scenario's arrays bit-identical; these tests hold the pieces
to that: the prepared solver against the general clamping solve, LAPACK called directly against numpy's
wrappers, and the trajectory samples an RK4 step reuses.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import uvms
from uvms.errors import NumericalError
from uvms.integrate import rk4_step, solve_square
from uvms.solvers import CLIKSolver
from uvms.solvers.clik import solve_with_held
from uvms.solvers.inverses import RCOND, prepared_svd_inverse
from uvms.state import KinematicState
from uvms.trajectory import CirclePath, PathTrajectory, RecentSamples, TrapezoidLaw


def hoang_setup():
    robot = uvms.load("hoang2011")
    task = uvms.FrameTask(robot, axes=("x", "y", "yaw"), orientation="euler", target=[0.0, -2.0, 0, 0, 0, 1.0])
    return robot, task


def test_a_solver_reused_over_configurations_and_targets_equals_fresh_clik_velocity_bit_for_bit(rng):
    robot, task = hoang_setup()
    potential = uvms.JointLimitPotential(robot)
    options = dict(gain=1.0, weights=np.array([1.0, 1.0, 500.0, 1.0, 1.0, 1.0]), potential=potential, alpha=10.0)
    solver = CLIKSolver(robot, task, **options)
    for index in range(30):
        q = robot.random_configuration(rng)
        task.set_target([rng.normal(), rng.normal(), 0.0, 0.0, 0.0, rng.normal()])
        task.set_target_velocity(rng.normal(size=6))
        fresh = CLIKSolver(robot, task, **options).solve(q)  # built for this call
        reused = solver.solve(q)
        assert np.array_equal(uvms.clik_velocity(robot, q, task, **options).v, fresh.v)  # the kept one
        assert np.array_equal(reused.v, fresh.v) and np.array_equal(reused.command, fresh.command)
        assert reused.sigma_min == fresh.sigma_min and reused.residual == fresh.residual
        assert np.array_equal(solver.velocity(KinematicState(robot, q, check=False)), fresh.v)
        if index == 0:  # the task's own rows: the residual of an exact (undamped, full-rank) solve is rounding
            assert fresh.residual < 1e-12 and fresh.sigma_min > 0.1


def test_the_prepared_path_is_the_clamping_solve_with_no_joint_held(rng):
    """The no-limit path and solve_with_held (joint clamping) are one computation: same bits, not only close."""
    robot, task = hoang_setup()
    potential = uvms.JointLimitPotential(robot)
    weights = rng.uniform(0.5, 50.0, robot.nv)
    for damping in (0.0, 0.05):
        solver = CLIKSolver(robot, task, gain=2.0, weights=weights, damping=damping, potential=potential, alpha=3.0)
        for _ in range(20):
            q = robot.random_configuration(rng)
            state = KinematicState(robot, q)
            jacobian, error, feedforward = task.terms(state)
            command = feedforward + 2.0 * error
            z0 = -3.0 * potential.gradient(q)
            held, _, _ = solve_with_held(jacobian, command, weights, damping, z0, np.arange(robot.nv), {})
            assert np.array_equal(solver.solve(state).v, held)


def test_a_frame_task_computes_its_three_terms_at_once_as_separately(rng):
    robot = uvms.load("bluerov2_alpha5")
    for orientation, axes in (("euler", ("x", "z", "roll", "yaw")), ("log", None), ("euler", ("x", "y", "z"))):
        task = uvms.FrameTask(robot, axes=axes, orientation=orientation)
        for _ in range(10):
            task.set_target(robot.fk(robot.random_configuration(rng)))
            task.set_target_velocity(rng.normal(size=6))
            state = KinematicState(robot, robot.random_configuration(rng))
            jacobian, error, feedforward = task.terms(state)
            assert np.array_equal(jacobian, task.jacobian(state))
            assert np.array_equal(error, task.error(state))
            assert np.array_equal(feedforward, task.feedforward(state))
            if orientation == "euler" and "yaw" in axes:  # the yaw row is a wrapped angle difference
                assert -np.pi <= error[-1] < np.pi


def test_the_compiled_svd_inverse_is_numpy_svd_to_rounding(rng):
    """The one-sided Jacobi SVD of the kernel against LAPACK's (numpy): the same inverse and sigma_min to rounding."""
    for rows, columns in ((3, 6), (6, 11), (6, 12), (7, 5)):
        jacobian = rng.normal(size=(rows, columns))
        for damping in (0.0, 0.1):
            inverse, sigma_min, used = prepared_svd_inverse(jacobian, damping)
            u, singular, vt = np.linalg.svd(jacobian, full_matrices=False)
            if damping:
                factors = singular / (singular**2 + damping**2)
            else:
                factors = np.where(singular > RCOND * singular[0], 1.0 / singular, 0.0)
            assert np.allclose(inverse, (vt.T * factors) @ u.T, rtol=0, atol=1e-13 * np.abs(inverse).max())
            assert sigma_min == (pytest.approx(singular[-1], rel=1e-13) if rows <= columns else 0.0)
            assert used == damping
        if rows <= columns:
            assert np.allclose(jacobian @ prepared_svd_inverse(jacobian, 0.0)[0], np.eye(rows), atol=1e-12)
    with pytest.raises(NumericalError, match="did not converge"):
        prepared_svd_inverse(np.full((3, 6), np.nan), 0.0)


def test_the_square_solve_of_the_rk4_stages_is_numpy_solve_and_refuses_a_singular_system(rng):
    for size in (3, 6, 12):
        matrix, rhs = rng.normal(size=(size, size)) + 3 * np.eye(size), rng.normal(size=size)
        assert np.array_equal(solve_square(matrix, rhs), np.linalg.solve(matrix, rhs))
    with pytest.raises(NumericalError, match="singular 2x2"):
        solve_square(np.ones((2, 2)), np.ones(2))


def misses(dt: float, steps: int) -> int:
    """Steps whose first time k dt is not bit for bit the last stage's (k - 1) dt + dt of the step before."""
    return sum((k - 1) * dt + dt != k * dt for k in range(1, steps))


def test_recent_samples_evaluate_the_trajectory_twice_per_rk4_step():
    law = TrapezoidLaw(speed=0.5, duration=4.0, accel_time=1.0)
    trajectory = PathTrajectory(CirclePath([0.0, 2.0, 0.0], [0.0, -2.0, 0.0]), law)
    times: list[float] = []

    def counted(t: float):
        times.append(t)
        return trajectory(t)

    recent = RecentSamples(counted)
    robot = uvms.load("hoang2011")
    model, dt = robot.model, 0.02
    q = robot.neutral()

    def rate(t, q, x):
        sample = recent(t)
        assert sample is recent(t)  # the same object for the same t, while it is kept
        return np.r_[sample.twist[:2], 0.0, np.zeros(robot.nv - 3)], x

    for k in range(50):
        t = k * dt
        q, _ = rk4_step(model, rate, t, q, np.zeros(0), dt, rate(t, q, np.zeros(0)))
    # t, t + dt/2 (the second and third stages), t + dt: the last is the next step's first when k dt rounds alike
    assert len(set(times)) == len(times) == 2 * 50 + 1 + misses(dt, 50)
    sample = recent(0.5)
    assert np.array_equal(sample.pose.translation, trajectory(0.5).pose.translation)
    assert np.array_equal(sample.twist, trajectory(0.5).twist)
    assert isinstance(sample.pose, pin.SE3)


def test_a_run_checks_its_configurations_once_and_refuses_a_bad_row_by_its_index(rng):
    robot = uvms.load("bluerov2_alpha5")
    rows = np.array([robot.random_configuration(rng) for _ in range(5)])
    assert np.array_equal(robot.check_configurations(rows), rows)
    bad = rows.copy()
    bad[3, 3:7] *= 1.5  # the vehicle's quaternion of row 3
    with pytest.raises(uvms.UVMSError, match="row 3: the rotation part of joint .* has norm 1.5"):
        robot.check_configurations(bad)
    bad = rows.copy()
    bad[1, -1] = np.nan
    with pytest.raises(uvms.UVMSError, match="non-finite"):
        robot.check_configurations(bad)


def test_the_vehicle_pose_and_arm_series_of_a_result_follow_its_configurations(rng):
    from uvms.series import SimulationResult

    robot = uvms.load("bluerov2_alpha5")
    rows = np.array([robot.random_configuration(rng) for _ in range(4)])
    result = SimulationResult(t=np.arange(4.0), q=rows, v=np.zeros((4, robot.nv)), robot=robot)
    expected = np.array([robot.base_values(q) for q in rows])
    expected[:, 3:6] = np.unwrap(expected[:, 3:6], axis=0)
    assert np.array_equal(result.vehicle_pose(), expected)
    assert np.array_equal(result.arm(), np.array([robot.arm_configuration(q) for q in rows]))
    result.q = rows[::-1].copy()  # a new series: computed again, not the kept one
    assert np.array_equal(result.vehicle_pose()[0, :3], robot.base_values(rows[-1])[:3])


# ------------------------------------------------------------------------ the set-based solver, prepared once
def alpha5_levels(robot, target):
    """Joint limits, vehicle attitude and speed limits above an end-effector pose (bench_set_based's problem)."""
    from uvms.tasks.objectives import JointLimits, JointVelocityLimits, VehicleAttitude, VehicleVelocityLimits

    return [JointLimits(robot, band=0.2), VehicleAttitude(robot, np.radians(5.0)), JointVelocityLimits(robot),
            VehicleVelocityLimits(robot, (0.5, 0.5)), uvms.FrameTask(robot, target=target)]


def alpha5_start(robot, rng):
    """A configuration with the vehicle tilted up to 4 deg (the attitude objective active or not) and a target."""
    tilt, direction = np.radians(4.0) * np.sqrt(rng.uniform()), rng.uniform(-np.pi, np.pi)
    q = robot.configuration(base=[0, 0, -5, tilt * np.cos(direction), tilt * np.sin(direction), rng.uniform(-3, 3)],
                            arm=rng.uniform(*arm_limits(robot)))
    return q, robot.fk(robot.random_configuration(rng))


def arm_limits(robot):
    """(lower, upper) (n_arm,) of the arm joints."""
    limit = uvms.Limit.joint_positions(robot)
    return limit.lower, limit.upper


@pytest.mark.parametrize("options", [dict(gain=2.0, dt=0.05), dict(gain=2.0, damping=0.05, eta=0.5, dt=0.05),
                                     dict(gain=[1.0, 1, 1, 3, 3, 3], weights=np.r_[np.full(6, 5.0), np.ones(5)]),
                                     dict(gain=2.0, free_floating=True, dt=0.05)])
def test_a_set_based_solver_reused_over_configurations_and_targets_equals_fresh_calls_bit_for_bit(rng, options):
    """Nothing carries over between calls of a prepared solver (its identity projector, box, gain are read only)."""
    from uvms.solvers.set_based import SetBasedSolver, set_based_step, set_based_velocity

    robot = uvms.load("bluerov2_alpha5")
    q, target = alpha5_start(robot, rng)
    levels = alpha5_levels(robot, target)
    if options.get("free_floating"):
        levels = [level for level in levels if type(level).__name__ not in ("VehicleAttitude",)]
    solver = SetBasedSolver(robot, levels, **options)
    task = levels[-1]
    active = scaled = 0
    for _ in range(25):
        q, target = alpha5_start(robot, rng)
        task.set_target(target)
        fresh = SetBasedSolver(robot, levels, **options).solve(q)  # built for this call
        reused = solver.solve(q)
        assert np.array_equal(set_based_velocity(robot, q, levels, **options).v, fresh.v)  # the kept one
        assert np.array_equal(reused.v, fresh.v) and np.array_equal(reused.command, fresh.command)
        assert reused.scales == fresh.scales and reused.level_residuals == fresh.level_residuals
        assert reused.sigma_min == fresh.sigma_min and reused.active == fresh.active
        assert np.array_equal(solver.velocity(KinematicState(robot, q, check=False)), fresh.v)
        if "dt" in options:
            assert np.array_equal(solver.step(q), set_based_step(robot, q, levels, options["dt"], **{
                key: value for key, value in options.items() if key != "dt"}).q)
        active += bool(fresh.active)
        scaled += min(fresh.scales) < 1.0
    assert active > 0  # the objectives were active in some calls, and the box bound the velocity in some
    assert scaled > 0 or "dt" not in options


def test_a_set_based_solver_refuses_bad_options_when_built():
    from uvms.solvers.set_based import SetBasedSolver

    robot = uvms.load("bluerov2_alpha5")
    levels = alpha5_levels(robot, robot.fk(robot.neutral()))
    with pytest.raises(uvms.SolverInputError, match="position_fraction must be in"):
        SetBasedSolver(robot, levels, position_fraction=1.5)
    with pytest.raises(uvms.SolverInputError, match="eta must be finite"):
        SetBasedSolver(robot, levels, eta=-1.0)
    with pytest.raises(uvms.SolverInputError, match="dt must be finite and > 0"):
        SetBasedSolver(robot, levels, dt=0.0)
    with pytest.raises(uvms.SolverInputError, match=r"gain must be a finite scalar >= 0, \(6,\)"):
        SetBasedSolver(robot, levels, gain=[1.0, 2.0])
    with pytest.raises(uvms.SolverInputError, match=r"step needs the step dt > 0 \[s\]: build the solver with dt="):
        SetBasedSolver(robot, levels).step(robot.neutral())
    with pytest.raises(uvms.NotARobot):
        SetBasedSolver("bluerov2_alpha5", levels)


def test_the_prepared_gain_is_apply_gains_products(rng):
    from uvms.solvers.checks import apply_gain, prepared_gain

    error, feedforward = rng.normal(size=4), rng.normal(size=4)
    matrix = rng.normal(size=(4, 4))
    for gain in (2.5, np.array(2.5), rng.uniform(0, 3, 4), matrix @ matrix.T):
        assert np.array_equal(prepared_gain(gain, 4)(error, feedforward), feedforward + apply_gain(gain, error))
    with pytest.raises(uvms.SolverInputError, match="positive"):
        prepared_gain(-matrix @ matrix.T, 4)


def test_the_largest_scale_keeps_the_sum_in_the_box_and_no_larger_one_does(rng):
    """The compiled saturation: the lowest level is scaled by the largest s that keeps the sum in the box."""
    from uvms.solvers.saturation import inside, scale_lowest_first

    for _ in range(300):
        upper = rng.uniform(0.1, 1.0, 5)
        lower = -rng.uniform(0.1, 1.0, 5)
        upper[rng.integers(5)] = np.inf  # an unbounded entry never limits the scale
        base = rng.uniform(lower, np.minimum(upper, 2.0)) * 0.9
        step = rng.normal(size=5) * rng.choice([0.1, 1.0, 10.0])
        step[rng.integers(5)] = 0.0
        total, (first, scale) = scale_lowest_first([base, step], lower, upper)
        assert first == 1.0 and 0.0 <= scale <= 1.0 and inside(total, lower, upper, 1e-12)
        assert np.array_equal(total, base + scale * step)
        if scale < 1.0:  # the largest: a bit more leaves the box
            assert not inside(base + (scale + 1e-6) * step, lower, upper, 1e-12)
    # a level above that leaves the box on its own: the lowest is dropped and that one scaled
    total, scales = scale_lowest_first([np.array([0.5, 0.0]), np.array([2.0, 0.0]), np.array([0.0, 5.0])],
                                       -np.ones(2), np.ones(2))
    assert scales == (1.0, 0.25, 0.0) and np.array_equal(total, [1.0, 0.0])


def test_the_levels_are_added_in_order_as_numpy_sums_them(rng):
    from uvms.solvers.set_based import sum_in_order

    for count in (1, 2, 3, 5):
        vectors = [rng.normal(size=11) * 10.0 ** rng.integers(-8, 8) for _ in range(count)]
        assert np.array_equal(sum_in_order(vectors), np.sum(vectors, axis=0))
        assert sum_in_order(vectors) is not vectors[0]  # a new array: the contributions stay as they were


# ------------------------------------------------------------------------ the one-call entries keep their solver
def test_clik_velocity_in_a_loop_keeps_its_solver_and_its_numbers(rng):
    """Calls with the same inputs reuse one solver; a target moved or a W changed in place gives the numbers of
    a solver built afresh for those inputs, bit for bit."""
    from uvms.solvers.prepared import PREPARED

    robot, task = hoang_setup()
    PREPARED.clear()
    weights = np.array([1.0, 1.0, 500.0, 1.0, 1.0, 1.0])
    for index in range(12):
        q = robot.random_configuration(rng)
        task.set_target([rng.normal(), rng.normal(), 0.0, 0.0, 0.0, rng.normal()])
        if index == 6:
            weights[2] = 3.0  # changed in place: a new key, a new solver
        reused = uvms.clik_velocity(robot, q, task, gain=1.5, weights=weights)
        fresh = CLIKSolver(robot, task, gain=1.5, weights=weights.copy()).solve(q)
        assert np.array_equal(reused.v, fresh.v) and reused.sigma_min == fresh.sigma_min
    assert len(PREPARED._entries) == 2  # one solver for each W


def test_the_kept_solvers_are_bounded_and_refusals_are_not_kept(rng):
    from uvms.solvers.prepared import PREPARED, SIZE

    robot, task = hoang_setup()
    PREPARED.clear()
    q = robot.random_configuration(rng)
    for gain in range(SIZE + 5):
        uvms.clik_velocity(robot, q, task, gain=float(gain))
    assert len(PREPARED._entries) == SIZE
    for _ in range(2):  # refused at every call, with its message
        with pytest.raises(uvms.SolverInputError, match="gain must be"):
            uvms.clik_velocity(robot, q, task, gain=-1.0)
    assert len(PREPARED._entries) == SIZE
    tasks = (t for t in [task])  # a generator is not keyed (a key would consume it): built for the call
    assert np.array_equal(uvms.clik_velocity(robot, q, tasks).v, uvms.clik_velocity(robot, q, [task]).v)


def test_the_keys_tell_values_and_objects_apart():
    from uvms.solvers.inverses import VariableDamping
    from uvms.solvers.prepared import Unkeyable, key_of

    held = []
    assert key_of(VariableDamping(0.1, 0.05), held) == key_of(VariableDamping(0.1, 0.05), held) and not held
    assert key_of(np.array([1.0, 2.0]), held) != key_of(np.array([1.0, 2.5]), held)
    assert key_of(np.array([1.0, 2.0]), held) != key_of(np.array([[1.0, 2.0]]), held)  # the shape counts
    assert key_of(1, held) != key_of(1.0, held) != key_of(True, held)
    first, second = object(), object()
    assert key_of(first, held) != key_of(second, held) and held == [first, second]
    with pytest.raises(Unkeyable):
        key_of(iter([1]), held)


@pytest.mark.parametrize("options, message", [
    (dict(gain="a"), r"gain must be a finite scalar >= 0, \(6,\) or \(6, 6\) \[1/s\], got 'a'"),
    (dict(gain=[1.0, "b"]), r"gain must be a finite scalar >= 0"),
    (dict(weights="x"), r"W must be \(11,\) or \(11, 11\) positive numbers, got 'x'"),
    (dict(speed_limits=None), "speed_limits must be a list of VelocityLimit objectives"),
    (dict(speed_limits=["x"]), "speed_limits must be a list of VelocityLimit objectives"),
])
def test_text_and_none_options_are_refused_by_what_is_valid(options, message):
    """Not a ValueError of numpy's conversion or a TypeError of Python's: the option named and what it takes."""
    from uvms.solvers.set_based import set_based_velocity

    robot = uvms.load("bluerov2_alpha5")
    levels = alpha5_levels(robot, robot.fk(robot.neutral()))
    with pytest.raises(uvms.SolverInputError, match=message):
        set_based_velocity(robot, robot.neutral(), levels, **options)
    if "speed_limits" not in options:  # CLIK reads its gain and W through the same checks
        hoang, task = hoang_setup()
        with pytest.raises(uvms.SolverInputError, match=r"(gain must be a finite scalar >= 0, \(3,\)|W must be \(6,\))"):
            uvms.clik_velocity(hoang, hoang.neutral(), task, **options)


@pytest.mark.parametrize("levels, message", [
    (None, "levels must be a non-empty list of levels.*got None"), (5, "got 5"), ([], "got \\[\\]"),
    ([None], "level 0: None is not a Task, an Inequality, a VelocityLimit or a list of them"),
    ([[]], "level 0 is empty"),
])
def test_malformed_levels_are_refused_by_what_a_level_holds(levels, message):
    from uvms.solvers.set_based import SetBasedSolver

    robot = uvms.load("bluerov2_alpha5")
    with pytest.raises(uvms.SolverInputError, match=message):
        SetBasedSolver(robot, levels)
