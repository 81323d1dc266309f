"""The solver layer (uvms.solvers): inverses, CLIK, null space, task priority, constraints, IK, initial
configuration."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import uvms
from uvms.errors import SolverInputError
from uvms.numerics.inverses import damped_weighted_inverse, dls, dls_solve, pinv, variable_damping, weighted_pinv
from uvms.solvers.constraints import SINGULAR_DAMPING
from uvms.solvers.priority import prioritized
from uvms.solvers.screws import davies_solve, network_matrix

from conftest import shipped


def clik_velocity(robot, q, tasks, **options):
    """One CLIK velocity from a solver built for this call."""
    return uvms.CLIKSolver(robot, tasks, **options).velocity(uvms.Configuration(robot, q))


def clik_step(robot, q, tasks, dt, **options):
    """One explicit-Euler CLIK step from a solver built for this call: q+ and the result (``velocity``)."""
    configuration = uvms.Configuration(robot, q)
    velocity = uvms.CLIKSolver(robot, tasks, dt=dt, **options).step(configuration, dt)
    return SimpleNamespace(q=configuration.q, velocity=velocity)


def priority_velocity(robot, q, levels, method="robust", **options):
    """One task-priority velocity from a solver built for this call."""
    return uvms.PrioritySolver(robot, levels, priority=method, **options).velocity(uvms.Configuration(robot, q))


def task_priority(jacobians, commands, method="robust", damping=0.0):
    """The prioritized solution of raw levels and its residuals |J_i v - c_i| per level."""
    v, sigmas = prioritized(jacobians, commands, method, damping)
    return SimpleNamespace(v=v, sigma_min=sigmas, residuals=tuple(
        float(np.linalg.norm(np.asarray(j) @ v - c)) for j, c in zip(jacobians, commands)))


def hoang_task(robot, target=(0.0, -2.0, 1.0)):
    x, y, phi = target
    return uvms.FrameTask(robot, axes=("x", "y", "yaw"), orientation="euler", target=[x, y, 0, 0, 0, phi])


# ---------------------------------------------------------------- inverses
def test_weighted_pinv_is_the_minimum_w_norm_solution(rng):
    for _ in range(20):
        jacobian = rng.normal(size=(3, 6))
        weights = np.diag(rng.uniform(0.5, 500, 6))
        xdot = rng.normal(size=3)
        w_inv = np.linalg.inv(weights)
        closed_form = w_inv @ jacobian.T @ np.linalg.inv(jacobian @ w_inv @ jacobian.T)  # hoang2011 eq. 15
        inverse = weighted_pinv(jacobian, weights)
        assert np.allclose(inverse, closed_form, atol=1e-10)
        qdot = inverse @ xdot
        assert np.allclose(jacobian @ qdot, xdot, atol=1e-12)
        null = (np.eye(6) - np.linalg.pinv(jacobian) @ jacobian) @ rng.normal(size=6)
        other = qdot + null
        assert np.allclose(jacobian @ other, xdot, atol=1e-10)
        assert qdot @ weights @ qdot < other @ weights @ other
    full = rng.normal(size=(6, 6))
    spd = full @ full.T + np.eye(6)
    jacobian = rng.normal(size=(3, 6))
    assert np.allclose(weighted_pinv(jacobian, spd),
                       np.linalg.inv(spd) @ jacobian.T @ np.linalg.inv(jacobian @ np.linalg.inv(spd) @ jacobian.T))


@pytest.mark.parametrize("weights", [np.diag([1, 1, -1.0]), np.array([[1, 2, 0], [0, 1, 0], [0, 0, 1.0]]), np.eye(2)])
def test_weighted_pinv_rejects_bad_weights(weights):
    with pytest.raises(SolverInputError):
        weighted_pinv(np.ones((2, 3)), weights)


def test_dls_bounded_at_and_near_singularities(rng):
    robot = shipped("hoang2011")
    for q2 in (0.0, 1e-6, 1e-3):  # stretched arm: the planar arm is singular at q2 = q3 = 0
        q = robot.configuration(base=[0, 0, 0.3], arm=[1.0, q2, 0.0])
        jacobian = robot.jacobian(q)[[0, 1, 5]][:, 3:]  # arm only, (3, 3)
        for damping in (1e-3, 0.05, 0.5):
            for _ in range(20):
                xdot = rng.normal(size=3)
                qdot = dls(jacobian, damping) @ xdot
                assert np.linalg.norm(qdot) <= np.linalg.norm(xdot) / (2 * damping) * (1 + 1e-9)
    tall = rng.normal(size=(8, 3))
    assert np.allclose(dls(tall, 0.1), np.linalg.solve(tall.T @ tall + 0.01 * np.eye(3), tall.T))
    wide = rng.normal(size=(3, 8))
    assert np.allclose(dls(wide, 0.1), wide.T @ np.linalg.inv(wide @ wide.T + 0.01 * np.eye(3)))


def test_one_inverse_module_its_forms_agree(rng):
    """The SVD form (with diagnostics), the matrix DLS and the normal-equation form are the same inverse."""
    for shape in ((3, 8), (6, 6), (6, 12)):
        jacobian, rhs = rng.normal(size=shape), rng.normal(size=shape[0])
        for damping in (1e-3, 0.1):
            inverse, sigma_min, used = damped_weighted_inverse(jacobian, None, damping)
            assert used == damping and sigma_min == pytest.approx(np.linalg.svd(jacobian, compute_uv=False)[-1])
            assert np.allclose(inverse, dls(jacobian, damping), atol=1e-12)
            assert np.allclose(dls_solve(jacobian, rhs, damping**2), inverse @ rhs, atol=1e-10)
        assert np.allclose(damped_weighted_inverse(jacobian, None, 0.0)[0], pinv(jacobian), atol=1e-10)
        weights = rng.uniform(0.5, 50, shape[1])
        assert np.allclose(damped_weighted_inverse(jacobian, weights, 0.0)[0], weighted_pinv(jacobian, weights),
                           atol=1e-10)
    with pytest.raises(SolverInputError, match="not positive definite"):
        dls_solve(np.zeros((3, 4)), np.ones(3), 0.0)


def test_variable_damping_formula():
    assert variable_damping(0.2, epsilon=0.1, lambda_max=0.5) == 0.0
    assert variable_damping(0.1, epsilon=0.1, lambda_max=0.5) == 0.0
    assert variable_damping(0.0, epsilon=0.1, lambda_max=0.5) == pytest.approx(0.5)
    assert variable_damping(0.05, epsilon=0.1, lambda_max=0.5) ** 2 == pytest.approx((1 - 0.25) * 0.25)


# -------------------------------------------------------------------- CLIK
@pytest.mark.parametrize("weights", [None, [1, 1, 1, 100, 100, 100], [1, 1, 500, 1, 1, 1]])
def test_clik_converges_monotonically_on_a_constant_target(weights):
    robot = shipped("hoang2011")
    task = hoang_task(robot)
    q = robot.configuration(base=[-1.0, -3.0, 1.0], arm=[2.0, 0.5, -0.5])
    norms = []
    for _ in range(400):
        step = clik_step(robot, q, task, 0.05, gain=2.0, weights=weights)
        norms.append(np.linalg.norm(step.velocity.error))
        q = step.q
        if norms[-1] <= 1e-11:
            break
    assert norms[-1] <= 1e-10
    assert all(later <= earlier for earlier, later in zip(norms, norms[1:]))


def test_clik_spatial_pose_task_and_free_floating_gjm(rng):
    robot = shipped("bluerov2_alpha5")
    q = robot.configuration(arm=[np.pi, 1.5, 2.0, 1.0, 0.0])
    target = robot.fk(q) * pin.SE3(pin.rpy.rpyToMatrix(0.1, -0.1, 0.2), np.array([0.05, 0.03, -0.04]))
    task = uvms.FrameTask(robot, target=target)
    for _ in range(300):
        q = clik_step(robot, q, task, 0.05, gain=2.0).q
    assert np.linalg.norm(task.full_error(uvms.Configuration(robot, q))) <= 1e-10
    snake = shipped("amundsen2018")
    q = snake.configuration(arm=[0.3, -0.3, 0.3, -0.3, 0.2, -0.2, 0.2, -0.2])
    target = snake.fk(q).translation + np.array([-0.05, -0.05, 0.05])
    position = uvms.FrameTask(snake, axes=("x", "y", "z"), target=pin.SE3(np.eye(3), target))
    for _ in range(100):
        step = clik_step(snake, q, position, 0.05, gain=3.0, free_floating=True)
        momentum = pin.computeCentroidalMap(snake.model, snake.data, q) @ step.velocity.v
        assert np.max(np.abs(momentum)) <= 1e-10  # the vehicle is passive
        q = step.q
    assert np.linalg.norm(snake.fk(q).translation - target) <= 1e-8


def test_nullspace_term_leaves_the_task_velocity_unchanged(rng):
    robot = shipped("hoang2011")
    task = hoang_task(robot)
    potential = uvms.tasks.MidRangePotential(robot)
    for weights in (None, [1, 1, 1, 100, 100, 100]):
        for _ in range(20):
            q = robot.random_configuration(rng)
            plain = clik_velocity(robot, q, task, weights=weights)
            with_null = clik_velocity(robot, q, task, weights=weights, potential=potential, alpha=10.0)
            jacobian = task.jacobian(uvms.Configuration(robot, q))
            assert np.linalg.norm(jacobian @ (with_null.v - plain.v)) <= 1e-12
            assert np.linalg.norm(with_null.v - plain.v) > 0  # the null-space motion is there


def test_joint_limit_potential_gradient_matches_finite_differences(rng):
    robot = shipped("hoang2011")
    potential = uvms.tasks.MidRangePotential(robot, weights=[1.0, 2.0, 0.5])
    q = robot.random_configuration(rng)
    gradient = potential.gradient(q)
    for index in range(robot.nv):
        step = np.zeros(robot.nv)
        step[index] = 1e-6
        numeric = (potential.value(pin.integrate(robot.model, q, step))
                   - potential.value(pin.integrate(robot.model, q, -step))) / 2e-6
        assert numeric == pytest.approx(gradient[index], abs=1e-8)
    assert potential.value(robot.configuration(arm=[0.75 * np.pi, 0, 0])) == 0.0


def test_joint_limits_never_violated_when_enabled():
    robot = shipped("hoang2011")
    lower, upper = robot.arm_limits
    task = uvms.FrameTask(robot, axes=("x", "y", "yaw"), orientation="euler", target=[0, 0, 0, 0, 0, 0])
    q = robot.configuration(arm=[0.2, 4.5, -4.5])  # near the limits
    clamped_any = False
    for _ in range(200):
        step = clik_step(robot, q, task, 0.1, gain=5.0, weights=[100, 100, 100, 1, 1, 1], enforce_limits=True)
        q = step.q
        arm = robot.arm_configuration(q)
        assert np.all(arm >= lower - 1e-12) and np.all(arm <= upper + 1e-12)
        clamped_any |= bool(step.velocity.limits_active)
    assert clamped_any


# ----------------------------------------------------------- task priority
def test_robust_priority_meets_the_first_task_exactly(rng):
    robot = shipped("santos2006")
    ee = uvms.FrameTask(robot, axes=("x", "y", "yaw"), target=[5.0, 4.0, 0, 0, 0, 0.5])
    rest = uvms.VehicleTask.at_rest(robot)
    for _ in range(30):
        q = robot.random_configuration(rng)
        for method in ("robust", "classic"):
            result = priority_velocity(robot, q, [ee, rest], method=method)
            assert result.task_residuals[0] <= 1e-11 * (1 + np.linalg.norm(result.v))  # machine precision
        classic = priority_velocity(robot, q, [ee, rest], method="classic")
        assert classic.task_residuals[1] <= 1e-9  # 3 + 3 rows on 6 DOF: both feasible
    jacobians = [rng.normal(size=(2, 5)), rng.normal(size=(2, 5)), rng.normal(size=(3, 5))]
    commands = [rng.normal(size=2), rng.normal(size=2), rng.normal(size=3)]
    three = task_priority(jacobians, commands, method="robust")
    assert three.residuals[0] <= 1e-12 and len(three.residuals) == 3


def test_classic_priority_and_robust_differ_only_below_the_first_level(rng):
    jacobian_1, jacobian_2 = rng.normal(size=(2, 4)), rng.normal(size=(2, 4))
    commands = [rng.normal(size=2), rng.normal(size=2)]
    classic = task_priority([jacobian_1, jacobian_2], commands, "classic")
    robust = task_priority([jacobian_1, jacobian_2], commands, "robust")
    assert classic.residuals[1] <= 1e-12  # 2 + 2 <= 4: both met
    assert robust.residuals[1] > 1e-6      # the robust form trades level 2 accuracy for no algorithmic singularity


# --------------------------------------------------------- kinematic constraint
def santos_constraint_cases(rng, count=20):
    """Random santos2006 configurations with the end-effector task, the vehicle constraint and their solution
    (the vehicle constraint's rows come first in ``result.command``: ``constraint_rows`` of them); those where
    [C; J] is near singular are damped, not yielded."""
    robot = shipped("santos2006")
    for _ in range(count):
        q = robot.random_configuration(rng)
        ee = uvms.FrameTask(robot, axes=("x", "y", "yaw"), target=[6.0, 4.5, 0, 0, 0, 0.8])
        ee.set_target_velocity([0.3, -0.2, 0, 0, 0, 0.1])
        constraint = uvms.VehicleTask(robot, velocities={"vx": 0.0, "vy": 0.0}, heading=0.78)
        result = uvms.ConstraintSolver(robot, [constraint, ee]).velocity(uvms.Configuration(robot, q))
        if result.sigma_min < SINGULAR_DAMPING.epsilon:  # near singular: damped (test_constraints.py), not exact
            assert result.damping > 0
            continue
        yield robot, q, ee, result, uvms.Configuration(robot, q)


constraint_rows = 3  # vx, vy and the heading


def test_kinematic_constraint_holds_exactly(rng):
    for _, q, ee, result, state in santos_constraint_cases(rng):
        assert abs(result.v[0]) <= 1e-12 and abs(result.v[1]) <= 1e-12
        yaw = np.arctan2(q[3], q[2])
        assert result.v[2] == pytest.approx(uvms.robot.conventions.wrap_angle(0.78 - yaw), abs=1e-12)
        command = result.command[constraint_rows:]  # the task's rows, after the constraint's
        assert np.linalg.norm(ee.jacobian(state) @ result.v - command) <= 1e-12


def test_kinematic_constraint_equals_the_screw_formulation(rng):
    """santos2006: close the UVMS chain with a virtual PPPS chain and solve N_s Y_s = -N_p Y_p."""
    for robot, _, ee, result, state in santos_constraint_cases(rng):
        network = network_matrix(state, ee.frame_id, planar=True)  # (3, 6 + 3): [S_uvms | -S_virtual]
        # primary: vehicle u, v, r (imposed) and the virtual chain magnitudes (end-effector vx, vy, wz)
        primary = [0, 1, 2, robot.nv + 0, robot.nv + 1, robot.nv + 2]
        command = result.command[constraint_rows:]  # the task's rows, after the constraint's
        values = [0.0, 0.0, result.v[2], *command[:2], command[2]]
        magnitudes = davies_solve(network, primary, values)
        assert np.allclose(magnitudes[3:6], result.v[3:6], atol=1e-12)
        assert np.allclose(network @ magnitudes, 0.0, atol=1e-12)  # the closed chain's circulation law


# --------------------------------------------------------------------- IK
def test_solve_ik_reaches_random_reachable_targets_within_limits(rng):
    robot = uvms.model.mount_arm(shipped("bluerov2_alpha5"), "ur5", placement=[0, 0, -0.2, np.pi, 0, 0], ee="arm_tool0")
    model = robot.model
    for seed in range(25):
        target = robot.fk(robot.random_configuration(rng))
        result = uvms.solve_ik(robot, target, rng=seed)
        assert result.success and result.error <= 1e-10
        pose_error = pin.log6(robot.fk(result.q).actInv(target)).vector
        assert np.linalg.norm(pose_error) <= 1e-9
        arm = slice(robot.nq_vehicle, robot.nq)
        assert np.all(result.q[arm] >= model.lowerPositionLimit[arm])
        assert np.all(result.q[arm] <= model.upperPositionLimit[arm])


def test_solve_ik_unreachable_target_is_not_a_false_success():
    arm = uvms.load(uvms.model.example_robot_urdf("ur5"))
    result = uvms.solve_ik(arm, [3.0, 0.0, 0.0, 0.0, 0.0, 0.0], restarts=3)
    assert not result.success
    assert np.isfinite(result.error) and result.error > 1.0
    assert np.all(np.isfinite(result.q))


def test_solve_ik_two_end_effectors_at_once(rng):
    robot = shipped("xiang2019")
    goal = robot.random_configuration(rng)
    targets = {"left_ee": robot.fk(goal, "left_ee"), "right_ee": robot.fk(goal, "right_ee")}
    result = uvms.solve_ik(robot, targets, rng=1)
    assert result.success
    for frame, target in targets.items():
        assert np.allclose(robot.fk(result.q, frame).homogeneous, target.homogeneous, atol=1e-9)


def test_solve_ik_ur5_random_targets_from_random_starts_all_within_limits(rng):
    """The benchmark's protocol in small: FK of uniform joints inside the limits, random starts, checked here."""
    arm = uvms.load(uvms.model.example_robot_urdf("ur5"))
    lower, upper = arm.arm_limits
    for index in range(150):
        target = arm.fk(arm.random_configuration(rng))
        result = uvms.solve_ik(arm, target, arm.random_configuration(rng), rng=index)
        pose = arm.fk(result.q)
        assert result.success
        assert np.linalg.norm(target.translation - pose.translation) <= 1e-10
        assert np.linalg.norm(pin.log3(target.rotation @ pose.rotation.T)) <= 1e-10
        assert np.all(result.q >= lower) and np.all(result.q <= upper)


def test_ik_projection_wraps_revolute_joints_by_two_pi_then_clips():
    from uvms.solvers.ik import JointBox

    robot = uvms.load(uvms.model.example_robot_urdf("ur5"))  # joints in [-2 pi, 2 pi], the elbow in [-pi, pi]
    box = JointBox.of(robot)
    assert JointBox.of(robot) is box  # built once per robot
    lower, upper = robot.arm_limits
    q = 0.5 * (lower + upper)
    q[0] = upper[0] + 0.25  # 2 pi + 0.25: wrapped to the lowest equal angle inside, 0.25 - 2 pi
    q[2] = lower[2] - 0.25  # the elbow's range is 2 pi: wrapped to upper - 0.25
    projected = box.project(q.copy())
    assert projected[0] == pytest.approx(0.25 - 2 * np.pi, abs=1e-12)
    assert projected[2] == pytest.approx(upper[2] - 0.25, abs=1e-12)
    assert np.array_equal(projected[[1, 3, 4, 5]], q[[1, 3, 4, 5]])
    assert np.allclose(robot.fk(projected).homogeneous, robot.fk(q).homogeneous, atol=1e-12)  # the same pose
    narrow = shipped("hoang2011")  # q1 in [0, 3 pi / 2]: 5.5 rad is 5.5 - 2 pi = -0.78 outside too: clipped
    q = narrow.neutral()
    q[narrow.nq_vehicle] = 5.5
    assert JointBox.of(narrow).project(q)[narrow.nq_vehicle] == pytest.approx(1.5 * np.pi)


def test_initial_configuration_of_hoang2011():
    robot = shipped("hoang2011")
    result = uvms.solvers.initial_configuration(robot, hoang_task(robot))
    assert result.success and result.residual <= 1e-10
    arm = robot.arm_configuration(result.q)
    # S can reach zero: q1 at mid-range 3 pi / 4, q2 = q3 = 0, the vehicle yaw takes the rest of phi
    assert arm == pytest.approx([0.75 * np.pi, 0.0, 0.0], abs=1e-6)
    assert result.potential <= 1e-12


# ------------------------------------------------------------- bad inputs
def test_bad_solver_inputs():
    robot = shipped("hoang2011")
    task = hoang_task(robot)
    q = robot.neutral()
    with pytest.raises(SolverInputError, match="gain"):
        clik_velocity(robot, q, task, gain=[1.0, 2.0])
    with pytest.raises(SolverInputError, match="positive definite"):
        clik_velocity(robot, q, task, weights=[1, 1, 1, 1, 1, -1])
    with pytest.raises(SolverInputError, match="damping"):
        clik_velocity(robot, q, task, damping=np.nan)
    with pytest.raises(SolverInputError, match="dt"):
        clik_step(robot, q, task, 0.0)
    with pytest.raises(uvms.UVMSError, match="no target"):
        clik_velocity(robot, q, uvms.FrameTask(robot))
    with pytest.raises(uvms.UVMSError, match="valid: log, euler"):
        uvms.FrameTask(robot, orientation="quaternion")
    with pytest.raises(uvms.UVMSError, match="valid for a planar base: vx, vy, wz"):
        uvms.VehicleTask(robot, velocities={"vz": 0.0})
    with pytest.raises(SolverInputError, match="alpha"):
        clik_velocity(robot, q, task, alpha=-1.0)
    with pytest.raises(SolverInputError, match="variable damping needs epsilon > 0"):
        uvms.solvers.VariableDamping(0.0, 0.1)
    with pytest.raises(SolverInputError, match="W must be symmetric"):
        clik_velocity(robot, q, task, weights=np.triu(np.ones((6, 6))), dt=0.1, enforce_limits=True)
    with pytest.raises(SolverInputError, match="dt"):
        clik_velocity(robot, q, task, enforce_limits=True)
    with pytest.raises(SolverInputError, match="restarts must be an integer >= 0"):
        uvms.solve_ik(robot, [0, 0, 0, 0, 0, 0], restarts=-1)
    with pytest.raises(SolverInputError, match="tolerance must be finite and > 0"):
        uvms.solve_ik(robot, [0, 0, 0, 0, 0, 0], tolerance=0.0)
    with pytest.raises(SolverInputError, match=f"needs a target pose for {robot.ee_frames[0]}: a pin.SE3 or"):
        uvms.solve_ik(robot, None)
    with pytest.raises(SolverInputError, match="needs a target pose for at least one frame"):
        uvms.solve_ik(robot, {})
    with pytest.raises(SolverInputError, match="max_iterations must be an integer >= 1"):
        uvms.solvers.initial_configuration(robot, task, max_iterations=0)
    with pytest.raises(SolverInputError, match="valid: classic, robust"):
        task_priority([np.eye(2)], [np.ones(2)], method="fast")
    with pytest.raises(SolverInputError, match="level 0 command must be 2 finite numbers"):
        task_priority([np.eye(2)], [np.array([1.0, np.nan])])
    with pytest.raises(SolverInputError, match="level 1: the Jacobian"):
        task_priority([np.eye(2), np.eye(3)], [np.ones(2), np.ones(3)])


def test_free_floating_on_a_fixed_base_is_one_clear_error():
    arm = uvms.load(uvms.model.example_robot_urdf("ur5"))  # fixed base: no generalized Jacobian
    assert arm.base_type == "fixed"
    task = uvms.FrameTask(arm, target=arm.fk(arm.neutral()))
    with pytest.raises(SolverInputError, match="ur5 has a fixed base: free_floating=True "
                                               "needs a floating or planar base"):
        clik_velocity(arm, arm.neutral(), task, free_floating=True)
    with pytest.raises(SolverInputError, match="fixed base"):
        clik_step(arm, arm.neutral(), task, 0.1, free_floating=True)
    assert np.all(np.isfinite(clik_velocity(arm, arm.neutral(), task).v))  # the same call without it works


# ------------------------------------------------------ property-based tests
finite = st.floats(-1e3, 1e3, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(arm=st.lists(st.floats(-4.7, 4.7), min_size=3, max_size=3), xdot=st.lists(finite, min_size=3, max_size=3),
       singular=st.booleans(), damping=st.sampled_from([0.0, 1e-3, 0.1]))
def test_solvers_never_return_nan(arm, xdot, singular, damping):
    robot = shipped("hoang2011")
    arm = np.clip(arm, *robot.arm_limits)
    if singular:
        arm[1:] = 0.0  # stretched arm
    q = robot.configuration(base=[0, 0, 0.1], arm=arm)
    task = hoang_task(robot, target=xdot)
    for free_floating in (False, True):
        result = clik_velocity(robot, q, task, damping=uvms.solvers.VariableDamping(0.1, 0.2) if damping else 0.0,
                               free_floating=free_floating, potential=uvms.tasks.MidRangePotential(robot), alpha=10.0)
        assert np.all(np.isfinite(result.v)) and np.isfinite(result.residual) and np.isfinite(result.sigma_min)
    state = uvms.Configuration(robot, q)
    jacobian = task.jacobian(state)[:, 3:]  # arm only: singular when stretched
    for inverse in (pinv(jacobian), dls(jacobian, damping)):
        assert np.all(np.isfinite(inverse @ np.asarray(xdot)))
    priority = priority_velocity(robot, q, [task, uvms.VehicleTask.at_rest(robot)], damping=damping)
    assert np.all(np.isfinite(priority.v))


# -------------------------------------------------------------- hot path
def test_compiled_cholesky_solve_matches_lapack_and_refuses_what_is_not_positive_definite(rng):
    from uvms.numerics._kernels.dense import cholesky_solve_in_place

    for size in (1, 3, 6, 12):
        factor = rng.normal(size=(size, size + 2))
        system = factor @ factor.T + 1e-3 * np.eye(size)  # SPD, condition up to ~1e4
        rhs = rng.normal(size=size)
        expected = np.linalg.solve(system, rhs)
        work, solution = system.copy(), rhs.copy()
        assert cholesky_solve_in_place(work, solution)
        assert np.allclose(solution, expected, rtol=1e-11, atol=1e-12)
        assert np.allclose(np.tril(work) @ np.tril(work).T, system, rtol=1e-12, atol=1e-12)  # L L^T = A
    indefinite = np.diag([1.0, -1.0, 2.0])
    assert not cholesky_solve_in_place(indefinite, np.ones(3))
    assert not cholesky_solve_in_place(np.full((2, 2), np.nan), np.ones(2))
    assert not cholesky_solve_in_place(np.ones((2, 2)), np.ones(2))  # singular: the second pivot is 0


def test_compiled_jacobi_svd_inverse_matches_lapack_wide_tall_and_rank_deficient(rng):
    from uvms.errors import NumericalError
    from uvms.numerics.inverses import VariableDamping, prepared_svd_inverse

    duplicated = rng.normal(size=(6, 12))
    duplicated[5] = duplicated[4]  # two identical task rows: rank 5
    combined = rng.normal(size=(4, 7))
    combined[3] = 0.5 * combined[0] - 0.3 * combined[1]
    graded = rng.normal(size=(6, 12)) * np.logspace(0, -6, 12)  # columns from 1 down to 1e-6
    for jacobian in (rng.normal(size=(6, 12)), rng.normal(size=(3, 6)), rng.normal(size=(6, 6)),
                     rng.normal(size=(9, 4)), duplicated, combined, graded, np.zeros((2, 3))):
        singular = np.linalg.svd(jacobian, compute_uv=False)
        wide = jacobian.shape[0] <= jacobian.shape[1]
        inverse, sigma_min, used = prepared_svd_inverse(jacobian, 0.0)
        assert used == 0.0
        scale = max(1.0, np.abs(np.linalg.pinv(jacobian, rcond=1e-12)).max())
        assert np.allclose(inverse, np.linalg.pinv(jacobian, rcond=1e-12), atol=1e-13 * scale)
        assert sigma_min == (pytest.approx(singular[-1], rel=1e-9, abs=1e-14) if wide else 0.0)
        for damping in (1e-3, 0.5):
            inverse, _, used = prepared_svd_inverse(jacobian, damping)
            rows = jacobian.shape[0]
            expected = jacobian.T @ np.linalg.inv(jacobian @ jacobian.T + damping**2 * np.eye(rows))
            assert used == damping and np.allclose(inverse, expected, atol=1e-11)
    # the variable damping reads sigma_min from the same SVD
    jacobian = np.diag([1.0, 0.02, 0.5]) @ rng.normal(size=(3, 5))
    _, sigma_min, used = prepared_svd_inverse(jacobian, VariableDamping(epsilon=0.5, lambda_max=0.2))
    assert sigma_min == pytest.approx(np.linalg.svd(jacobian, compute_uv=False)[-1], rel=1e-12)
    assert used == pytest.approx(np.sqrt(1 - (sigma_min / 0.5) ** 2) * 0.2, rel=1e-14)
    bad = rng.normal(size=(3, 5))
    bad[1, 2] = np.nan
    with pytest.raises(NumericalError, match="did not converge"):
        prepared_svd_inverse(bad, 0.1)


def test_compiled_pose_error_and_joint_box_match_pinocchio_and_numpy(rng):
    from uvms.numerics._kernels.boxes import project_into_box
    from uvms.numerics._kernels.pose import pose_error_norm, rotation_to_target

    for _ in range(50):  # seeded poses: log3 is ill-conditioned near pi, an unseeded draw made the bound flaky
        pose, target = (pin.SE3(pin.exp3(rng.normal(size=3)), rng.normal(size=3)) for _ in range(2))
        relative = np.empty((3, 3))
        rotation_to_target(pose.homogeneous, target.rotation, relative)
        assert np.allclose(relative, target.rotation @ pose.rotation.T, atol=1e-15)
        error = np.empty(6)
        norm = pose_error_norm(pose.homogeneous, target.translation, pin.log3(relative), error)
        expected = np.concatenate([target.translation - pose.translation, pin.log3(relative)])
        assert np.allclose(expected[3:], pin.log3(target.rotation @ pose.rotation.T), atol=1e-12)
        assert np.allclose(error, expected, atol=1e-14) and norm == pytest.approx(np.linalg.norm(expected), rel=1e-14)
    # the box: a revolute angle outside its limits wraps by 2 pi when that lands inside, the rest is clipped
    lower, upper = np.array([-1.0, -3.0, 0.0, -0.5]), np.array([1.0, 3.0, 0.5, 6.0])
    turns = np.array([True, True, False, True])
    index = np.array([0, 2, 3, 5], dtype=np.int64)
    for _ in range(200):
        q = rng.uniform(-12.0, 12.0, 6)
        values = q[index]
        wrapped = lower + np.mod(values - lower, 2 * np.pi)
        moved = np.where(((values < lower) | (values > upper)) & turns & (wrapped <= upper), wrapped, values)
        expected = q.copy()
        expected[index] = np.clip(moved, lower, upper)
        project_into_box(q, index, lower, upper, turns)
        assert np.array_equal(q, expected)
