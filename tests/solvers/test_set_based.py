"""The set-based solver (uvms.solvers.set_based.SetBasedSolver): built once, it gives the numbers of a solver built
at every call bit for bit; it refuses bad options when built; the saturation and the sum of the levels it uses."""

from __future__ import annotations

import numpy as np
import pytest

import uvms
from uvms.robot.configuration import Configuration


def hoang_setup():
    robot = uvms.load("hoang2011")
    task = uvms.FrameTask(robot, axes=("x", "y", "yaw"), orientation="euler", target=[0.0, -2.0, 0, 0, 0, 1.0])
    return robot, task


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
    """Nothing carries over between calls of a solver (its identity projector, box, gain are read only)."""
    from uvms.solvers import SetBasedSolver

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
        fresh = SetBasedSolver(robot, levels, **options).velocity(Configuration(robot, q))  # built for this call
        reused = solver.velocity(Configuration(robot, q))
        assert np.array_equal(reused.v, fresh.v) and np.array_equal(reused.command, fresh.command)
        assert reused.scales == fresh.scales and reused.task_residuals == fresh.task_residuals
        assert reused.sigma_min == fresh.sigma_min and reused.active == fresh.active
        assert np.array_equal(solver.velocity(Configuration(robot, q, check=False)).v, fresh.v)
        if "dt" in options:
            kept, built = Configuration(robot, q), Configuration(robot, q)
            solver.step(kept, options["dt"])
            SetBasedSolver(robot, levels, **options).step(built, options["dt"])  # a solver built for the step
            assert np.array_equal(kept.q, built.q)
        active += bool(fresh.active)
        scaled += min(fresh.scales) < 1.0
    assert active > 0  # the objectives were active in some calls, and the box bound the velocity in some
    assert scaled > 0 or "dt" not in options


@pytest.mark.parametrize("options", [dict(gain=2.0, dt=0.05), dict(gain=2.0, damping=0.05, eta=0.5, dt=0.05)])
def test_a_stage_velocity_reads_the_plan_s_own_stacks_and_gives_a_result_s_velocity_bit_for_bit(rng, options):
    """stage_velocity solves from the plan's own stacks (HierarchyPlan.stage_stacks, written over at each call, a
    view per block made once): the stacks evaluate makes and the v of velocity(...) at every configuration in
    turn, the objectives active at some and the box binding at some."""
    from uvms.solvers import SetBasedSolver

    robot = uvms.load("bluerov2_alpha5")
    q, target = alpha5_start(robot, rng)
    levels = alpha5_levels(robot, target)
    solver = SetBasedSolver(robot, levels, **options)
    active = scaled = 0
    for _ in range(25):
        q, target = alpha5_start(robot, rng)
        levels[-1].set_target(target)
        state = Configuration(robot, q)
        staged = solver.stage_velocity(state)
        stacks = solver.plan.stage_stacks(state)  # the same buffers, written again at the same state
        assert stacks[0] is solver.plan.stage_stacks(state)[0]
        hierarchy = solver.plan.evaluate(state)
        for own, made in zip(stacks, (hierarchy.jacobians, hierarchy.references, hierarchy.activations)):
            assert np.array_equal(own, made) and own is not made
        result = solver.velocity(state)
        assert np.array_equal(staged, result.v)
        active += bool(result.active)
        scaled += min(result.scales) < 1.0
    assert active > 0 and scaled > 0


def test_a_set_based_solver_refuses_bad_options_when_built():
    from uvms.solvers.set_based import SetBasedSolver

    robot = uvms.load("bluerov2_alpha5")
    levels = alpha5_levels(robot, robot.fk(robot.neutral()))
    with pytest.raises(uvms.errors.SolverInputError, match="position_fraction must be in"):
        SetBasedSolver(robot, levels, position_fraction=1.5)
    with pytest.raises(uvms.errors.SolverInputError, match="eta must be finite"):
        SetBasedSolver(robot, levels, eta=-1.0)
    with pytest.raises(uvms.errors.SolverInputError, match="dt must be finite and > 0"):
        SetBasedSolver(robot, levels, dt=0.0)
    with pytest.raises(uvms.errors.SolverInputError, match=r"gain must be a finite scalar >= 0, \(6,\)"):
        SetBasedSolver(robot, levels, gain=[1.0, 2.0])
    with pytest.raises(uvms.errors.SolverInputError, match=r"dt must be finite and > 0"):
        SetBasedSolver(robot, levels).step(Configuration(robot, robot.neutral()), 0.0)
    with pytest.raises(uvms.errors.NotARobot):
        SetBasedSolver("bluerov2_alpha5", levels)


@pytest.mark.parametrize("options, message", [
    (dict(gain="a"), r"gain must be a finite scalar >= 0, \(6,\) or \(6, 6\) \[1/s\], got 'a'"),
    (dict(gain=[1.0, "b"]), r"gain must be a finite scalar >= 0"),
    (dict(weights="x"), r"W must be \(11,\) or \(11, 11\) positive numbers, got 'x'"),
    (dict(speed_limits=None), "speed_limits must be a list of VelocityLimit objectives"),
    (dict(speed_limits=["x"]), "speed_limits must be a list of VelocityLimit objectives"),
])
def test_text_and_none_options_are_refused_by_what_is_valid(options, message):
    """Not a ValueError of numpy's conversion or a TypeError of Python's: the option named and what it takes."""
    from uvms.solvers import SetBasedSolver

    robot = uvms.load("bluerov2_alpha5")
    levels = alpha5_levels(robot, robot.fk(robot.neutral()))
    with pytest.raises(uvms.errors.SolverInputError, match=message):
        SetBasedSolver(robot, levels, **options)
    if "speed_limits" not in options:  # CLIK reads its gain and W through the same checks
        hoang, task = hoang_setup()
        with pytest.raises(uvms.errors.SolverInputError, match=r"(gain must be a finite scalar "
                                                               r">= 0, \(3,\)|W must be \(6,\))"):
            uvms.CLIKSolver(hoang, task, **options)


@pytest.mark.parametrize("levels, message", [
    (None, "levels must be a non-empty list of levels.*got None"), (5, "got 5"), ([], "got \\[\\]"),
    ([None], "level 0: None is not a Task, an Inequality, a VelocityLimit or a list of them"),
    ([[]], "level 0 is empty"),
])
def test_malformed_levels_are_refused_by_what_a_level_holds(levels, message):
    from uvms.solvers.set_based import SetBasedSolver

    robot = uvms.load("bluerov2_alpha5")
    with pytest.raises(uvms.errors.SolverInputError, match=message):
        SetBasedSolver(robot, levels)


def saturated(contributions, lower, upper, maximum=None, check_inside=True):
    """saturated_sum_into over the box [lower, upper] (containing 0): rate rows of q = 0, dt = 1, fraction = 1."""
    from uvms.numerics._kernels.boxes import saturated_sum_into

    stacked = np.array(contributions, dtype=float)
    size = stacked.shape[1]
    finite_low, finite_high = np.isfinite(lower), np.isfinite(upper)
    rows = np.flatnonzero(finite_low | finite_high).astype(np.int64)
    total, scales = np.empty(size), np.empty(len(contributions))
    low, high = np.where(finite_low, lower, -1e300)[rows], np.where(finite_high, upper, 1e300)[rows]
    ratio = saturated_sum_into(stacked, stacked, np.zeros(size), rows, rows, low, high, 1.0, 1.0,
                               np.full(size, np.inf) if maximum is None else maximum, check_inside, 1e-12, total,
                               scales)
    return total, tuple(scales.tolist()), ratio


def inside(values, lower, upper, tolerance=1e-12):
    return bool(np.all(values >= lower - tolerance) and np.all(values <= upper + tolerance))


def test_the_largest_scale_keeps_the_sum_in_the_box_and_no_larger_one_does(rng):
    """The compiled saturation: the lowest level is scaled by the largest s that keeps the sum in the box."""
    for _ in range(300):
        upper = rng.uniform(0.1, 1.0, 5)
        lower = -rng.uniform(0.1, 1.0, 5)
        upper[rng.integers(5)] = np.inf  # an unbounded entry never limits the scale
        base = rng.uniform(lower, np.minimum(upper, 2.0)) * 0.9
        step = rng.normal(size=5) * rng.choice([0.1, 1.0, 10.0])
        step[rng.integers(5)] = 0.0
        total, (first, scale), ratio = saturated([base, step], lower, upper)
        assert first == 1.0 and 0.0 <= scale <= 1.0 and inside(total, lower, upper) and ratio == 0.0  # no speed limit
        assert np.array_equal(total, 1.0 * base + scale * step)
        if scale < 1.0:  # the largest: a bit more leaves the box
            assert not inside(base + (scale + 1e-6) * step, lower, upper)
    # a level above that leaves the box on its own: the lowest is dropped and that one scaled
    total, scales, _ = saturated([np.array([0.5, 0.0]), np.array([2.0, 0.0]), np.array([0.0, 5.0])], -np.ones(2),
                                 np.ones(2))
    assert scales == (1.0, 0.25, 0.0) and np.array_equal(total, [1.0, 0.0])
    # the speed limits clip the box: |v_i| <= 0.5 scales the second level to 0.25 / 2
    total, scales, ratio = saturated([np.array([0.25, 0.0]), np.array([2.0, 0.0])], -np.ones(2), np.ones(2),
                                     maximum=np.array([0.5, np.inf]))
    assert scales == (1.0, 0.125) and np.array_equal(total, [0.5, 0.0]) and ratio == 1.0


def test_the_levels_are_added_in_order_as_numpy_sums_them(rng):
    """Inside the box (or without one) the velocity is the plain sum, numpy's numbers, every scale 1; free
    floating (no inside check) scales even then by 1."""
    for count in (1, 2, 3, 5):
        vectors = [rng.normal(size=11) * 10.0 ** rng.integers(-8, 8) for _ in range(count)]
        unbounded = np.full(11, np.inf)
        for check_inside in (True, False):
            total, scales, _ = saturated(vectors, -unbounded, unbounded, check_inside=check_inside)
            assert np.array_equal(total, np.sum(vectors, axis=0)) and scales == (1.0,) * count
        total, scales, _ = saturated(vectors, -np.full(11, 1e30), np.full(11, 1e30), check_inside=False)
        assert np.array_equal(total, np.sum(vectors, axis=0)) and scales == (1.0,) * count


@pytest.mark.parametrize("method", ["set_based", "hqp"])
def test_a_second_hierarchy_at_the_same_q_reads_the_shared_rows_and_gives_the_numbers_of_its_own(rng, method):
    """The actuated chain's two solves at one q (the vehicle's level below the task, then on top): with an ItemRows
    the second evaluates only its own vehicle level, and both give the numbers of solves that evaluate everything
    themselves, bit for bit; at another q the rows are evaluated again."""
    from uvms.solvers import SOLVERS
    from uvms.solvers.item_rows import ItemRows
    from uvms.tasks.vehicle import VehicleTask

    robot = uvms.load("bluerov2_alpha5")
    q, target = alpha5_start(robot, rng)
    *objectives, task = [level for level in alpha5_levels(robot, target) if "Velocity" not in type(level).__name__]
    below, above = VehicleTask.at_rest(robot), VehicleTask.at_rest(robot)
    below.velocity_values[:] = rng.normal(size=6)
    above.velocity_values[:] = rng.normal(size=6)
    cls = SOLVERS[method]
    assert cls.shares_rows
    options = {"dt": 0.05} if method == "hqp" else {}
    reference, arm = cls(robot, [*objectives, task, [below]], **options), cls(robot, [[above], *objectives, task],
                                                                               **options)
    calls = {"objectives": 0, "task": 0}

    def counted(item, key):
        method_name = "rows_into" if key == "objectives" else "terms"  # what a hierarchy's evaluation calls
        original = getattr(item, method_name)

        def wrapper(state, *out):
            calls[key] += 1
            return original(state, *out)

        setattr(item, method_name, wrapper)

    for objective in objectives:
        counted(objective, "objectives")
    counted(task, "task")
    shared = ItemRows()
    for _ in range(3):
        q, target = alpha5_start(robot, rng)
        task.set_target(target)
        shared.clear()  # the target moved
        state = Configuration(robot, q)
        first, second = reference.velocity(state, shared=shared), arm.velocity(state, shared=shared)
        assert calls == {"objectives": len(objectives), "task": 1}  # once each for both solves
        assert np.array_equal(first.v, reference.velocity(Configuration(robot, q)).v)
        assert np.array_equal(second.v, arm.velocity(Configuration(robot, q)).v)
        calls.update(objectives=0, task=0)
    moved = Configuration(robot, pin_moved(robot, q))
    arm.velocity(moved, shared=shared)  # another q: evaluated again, not read
    assert calls == {"objectives": len(objectives), "task": 1}


def pin_moved(robot, q):
    """q moved a little along every velocity coordinate."""
    import pinocchio as pin

    return pin.integrate(robot.model, q, np.full(robot.nv, 1e-3))


def test_an_objectives_rows_are_its_value_jacobian_activation_and_reference(rng):
    """Inequality.rows (one call per step) gives what value, jacobian, activation and reference give one by one, for
    the tilt (tilted and level: a zero row) and the plane clearance (the vehicle, a tool point)."""
    from uvms.tasks.objectives import JointLimits, PlaneClearance, VehicleAttitude

    robot = uvms.load("bluerov2_alpha5")
    objectives = [JointLimits(robot, band=0.2), VehicleAttitude(robot, np.radians(5.0), band=np.radians(4.0)),
                  PlaneClearance(robot, "vehicle", [0, 0, -5.5], [0, 0, 1], min=0.3, band=0.3),
                  PlaneClearance(robot, robot.ee_frames[0], [1, 0, -5], [0.3, -0.2, 1], min=0.1, band=0.5)]
    level = robot.configuration(base=[0, 0, -5, 0, 0, 0.4], arm=[3.0, 1.8, 1.8, 1.0, 0.0])
    for q in [level, *(alpha5_start(robot, rng)[0] for _ in range(3))]:
        state = Configuration(robot, q)
        for objective in objectives:
            rows = objective.rows(state)
            value = objective.value(state)
            np.testing.assert_allclose(rows.value, value, rtol=0, atol=1e-15)
            np.testing.assert_allclose(rows.jacobian, objective.jacobian(state), rtol=0, atol=1e-15)
            np.testing.assert_allclose(rows.activation, objective.activation(value), rtol=0, atol=1e-15)
            np.testing.assert_allclose(rows.reference, objective.reference(value), rtol=0, atol=1e-15)
    tilt = objectives[1].rows(Configuration(robot, level))
    assert tilt.value[0] < 1e-12 and not tilt.jacobian.any()  # level: the tilt's gradient taken as 0
    assert tilt.activation[0] == 0.0  # deep inside the valid set


def test_the_fused_icat_and_box_call_is_the_two_calls_in_turn(rng):
    """icat_saturated_into (the set-based step's one compiled call) gives the numbers of icat_into then
    saturated_sum_into: the solved columns, the scales, the speed ratio, the sigma_min and the damping, with the box
    binding (the lowest level scaled) and not."""
    from uvms.numerics._kernels.boxes import saturated_sum_into
    from uvms.numerics._kernels.icat import icat_into, icat_saturated_into
    from uvms.numerics.inverses import RCOND, WeightedInverse

    size = 6
    kernel_weights = WeightedInverse(rng.uniform(0.5, 2.0, size), size).kernel_weights
    activations = [np.array([0.0, 0.4, 1.0]), np.ones(3), np.array([0.7, 0.2])]
    jacobians = np.concatenate([rng.normal(size=(a.size, size)) for a in activations])
    references, stacked = rng.normal(size=8), np.concatenate(activations)
    offsets, equality = np.array([0, 3, 6, 8], dtype=np.int64), np.array([False, True, False])
    q, rows = rng.normal(size=size), np.array([1, 4], dtype=np.int64)  # two rate rows: joints 1 and 4
    low, high = q[rows] - 0.02, q[rows] + 0.03
    scaled_any = False
    for maximum in (np.full(size, np.inf), np.full(size, 0.05)):  # no speed limit; one that binds
        constants = (jacobians, references, stacked, offsets, equality, *kernel_weights, 0.02, 0.0, 0.0, RCOND, 0.5)
        contributions, sigmas = np.empty((3, size)), np.empty(3)
        converged, largest = icat_into(*constants, contributions, sigmas)
        total, scales = np.empty(size), np.empty(3)
        ratio = saturated_sum_into(contributions, contributions, q, rows, rows, low, high, 0.1, 1.0, maximum, True,
                                   1e-12, total, scales)
        fused = np.empty((3, size)), np.empty(3), np.empty(size), np.empty(3)
        converged_fused, largest_fused, ratio_fused = icat_saturated_into(*constants, q, rows, rows, low, high, 0.1,
                                                                          1.0, maximum, 1e-12, *fused)
        assert converged and converged_fused and largest_fused == pytest.approx(largest, rel=1e-15)
        assert ratio_fused == pytest.approx(ratio, rel=1e-15, abs=1e-300)
        for got, expected in zip(fused, (contributions, sigmas, total, scales)):
            np.testing.assert_allclose(got, expected, rtol=1e-15, atol=1e-300)
        scaled_any = scaled_any or bool(np.any(scales < 1.0))
    assert scaled_any and ratio > 0.5  # the box bound the sum in a case (measured scales < 1 and a ratio of ~1)



def test_activity_is_read_from_the_objectives_rows_without_forming_the_levels(rng):
    """A set-based result's activity (what a recorder reads at every row) comes from the objectives' rows it was
    given, in priority order, without forming its levels; the same answer as the levels' objectives give."""
    from uvms.solvers import SetBasedSolver

    robot = uvms.load("bluerov2_alpha5")
    for _ in range(5):
        q, target = alpha5_start(robot, rng)
        result = SetBasedSolver(robot, alpha5_levels(robot, target), dt=0.05).velocity(Configuration(robot, q))
        activity = result.activity
        assert "levels" not in vars(result)  # the levels not formed for it
        assert list(activity) == ["joint_limits", "vehicle_attitude"]
        assert activity == {status.name: status.active for status in result.objectives}
        assert activity == {rows.name: bool(np.any(rows.activation > 0))
                            for level in result.levels for rows in level.objectives}


def test_a_second_hierarchy_copies_the_objectives_rows_of_the_first_run_by_run(rng):
    """The coordination's arm hierarchy at the reference's q copies the rows the reference's evaluation wrote: the
    three consecutive objectives and the task (the same scalar gain: its command is the reference's numbers) as one
    run of rows (not evaluated, not copied one by one), its own vehicle level evaluated; its stacks are those of an
    evaluation of its own. With another gain the task is evaluated with it."""
    from uvms.solvers import SetBasedSolver
    from uvms.solvers.item_rows import ItemRows
    from uvms.tasks.objectives import PlaneClearance
    from uvms.tasks.vehicle import VehicleTask

    robot = uvms.load("bluerov2_alpha5")
    q, target = alpha5_start(robot, rng)
    *objectives, task = [level for level in alpha5_levels(robot, target) if "Velocity" not in type(level).__name__]
    objectives.append(PlaneClearance(robot, "vehicle", [0, 0, -5.55], [0, 0, 1], min=0.5, band=0.1))
    below, above = VehicleTask.at_rest(robot), VehicleTask.at_rest(robot)
    above.velocity_values[:] = rng.normal(size=6)
    reference = SetBasedSolver(robot, [*objectives, task, [below]], dt=0.05)
    arm = SetBasedSolver(robot, [[above], *objectives, task], dt=0.05)
    state, shared = Configuration(robot, q), ItemRows()
    reference.velocity(state, shared=shared)
    assert shared.source[0] is reference.plan
    calls = []
    for item, method in [*((objective, "rows_into") for objective in objectives), (task, "terms")]:
        original = getattr(item, method)
        setattr(item, method, lambda *a, original=original: calls.append(1) or original(*a))
    copied = arm.plan.evaluate(state, shared)
    assert not calls  # read from the reference's stacks
    alone = arm.plan.evaluate(Configuration(robot, q))
    runs, taken, evaluated = arm.plan._gathering(reference.plan)
    rows = sum(objective.dim for objective in objectives) + task.dim
    assert runs == [(slice(6, 6 + rows), slice(0, rows))] and len(taken) == 4 and len(evaluated) == 1
    other_gain = SetBasedSolver(robot, [[above], *objectives, task], dt=0.05, gain=2.0)
    runs, taken, evaluated = other_gain.plan._gathering(reference.plan)
    assert runs == [(slice(6, 6 + rows - task.dim), slice(0, rows - task.dim))] and len(evaluated) == 2
    with_gain = other_gain.plan.evaluate(state, shared)
    assert calls  # the task evaluated, its command with K = 2
    _, error, feedforward = task.terms(state)
    np.testing.assert_array_equal(with_gain.references[-task.dim:], feedforward + 2.0 * error)
    for name in ("jacobians", "references", "activations"):
        np.testing.assert_allclose(getattr(copied, name), getattr(alone, name), rtol=1e-15, atol=1e-300)
    assert [rows.name for rows in copied.objective_rows()] == [objective.name for objective in objectives]
    assert np.array_equal(arm.velocity(state, shared=shared).v, arm.velocity(Configuration(robot, q)).v)
