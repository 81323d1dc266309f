"""CLIK (uvms.solvers.clik): a CLIKSolver built once gives the numbers of a solver built at every call bit for bit;
a solver built after an input changed in place reads the new value; the pose hot path is CLIK on a FrameTask."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import uvms
from uvms import Configuration
from uvms.solvers import CLIKSolver
from uvms.solvers.clik import solve_with_held


def hoang_setup():
    robot = uvms.load("hoang2011")
    task = uvms.FrameTask(robot, axes=("x", "y", "yaw"), orientation="euler", target=[0.0, -2.0, 0, 0, 0, 1.0])
    return robot, task


def test_a_solver_reused_over_configurations_and_targets_equals_a_fresh_one_bit_for_bit(rng):
    robot, task = hoang_setup()
    potential = uvms.tasks.MidRangePotential(robot)
    options = dict(gain=1.0, weights=np.array([1.0, 1.0, 500.0, 1.0, 1.0, 1.0]), potential=potential, alpha=10.0)
    solver = CLIKSolver(robot, task, **options)
    for index in range(30):
        q = robot.random_configuration(rng)
        task.set_target([rng.normal(), rng.normal(), 0.0, 0.0, 0.0, rng.normal()])
        task.set_target_velocity(rng.normal(size=6))
        fresh = CLIKSolver(robot, task, **options).velocity(Configuration(robot, q))  # built for this call
        reused = solver.velocity(Configuration(robot, q))
        assert np.array_equal(reused.v, fresh.v) and np.array_equal(reused.command, fresh.command)
        assert reused.sigma_min == fresh.sigma_min and reused.residual == fresh.residual
        assert np.array_equal(solver.velocity(Configuration(robot, q, check=False)).v, fresh.v)
        if index == 0:  # the task's own rows: the residual of an exact (undamped, full-rank) solve is rounding
            assert fresh.residual < 1e-12 and fresh.sigma_min > 0.1


def test_the_solver_path_is_the_clamping_solve_with_no_joint_held(rng):
    """The no-limit path and solve_with_held (joint clamping) are one computation: same bits, not only close."""
    robot, task = hoang_setup()
    potential = uvms.tasks.MidRangePotential(robot)
    weights = rng.uniform(0.5, 50.0, robot.nv)
    for damping in (0.0, 0.05):
        solver = CLIKSolver(robot, task, gain=2.0, weights=weights, damping=damping, potential=potential, alpha=3.0)
        for _ in range(20):
            q = robot.random_configuration(rng)
            state = Configuration(robot, q)
            jacobian, error, feedforward = task.terms(state)
            command = feedforward + 2.0 * error
            z0 = -3.0 * potential.gradient(q)
            held, _, _ = solve_with_held(jacobian, command, weights, damping, z0, np.arange(robot.nv), {})
            assert np.array_equal(solver.velocity(state).v, held)


def test_the_prepared_gain_is_apply_gains_products(rng):
    from uvms.numerics.checks import apply_gain, prepared_gain

    error, feedforward = rng.normal(size=4), rng.normal(size=4)
    matrix = rng.normal(size=(4, 4))
    for gain in (2.5, np.array(2.5), rng.uniform(0, 3, 4), matrix @ matrix.T):
        assert np.array_equal(prepared_gain(gain, 4)(error, feedforward), feedforward + apply_gain(gain, error))
    with pytest.raises(uvms.errors.SolverInputError, match="positive"):
        prepared_gain(-matrix @ matrix.T, 4)


# ------------------------------------------------------------------ a solver built per input reads its inputs
def test_a_solver_built_for_each_input_in_a_loop_reads_the_current_inputs(rng):
    """A target moved or a W changed in place gives the numbers of a solver built afresh for those inputs."""
    robot, task = hoang_setup()
    weights = np.array([1.0, 1.0, 500.0, 1.0, 1.0, 1.0])
    for index in range(12):
        q = robot.random_configuration(rng)
        task.set_target([rng.normal(), rng.normal(), 0.0, 0.0, 0.0, rng.normal()])
        if index == 6:
            weights[2] = 3.0  # changed in place: read by the next solver built
        called = CLIKSolver(robot, task, gain=1.5, weights=weights).velocity(Configuration(robot, q))
        fresh = CLIKSolver(robot, task, gain=1.5, weights=weights.copy()).velocity(Configuration(robot, q))
        assert np.array_equal(called.v, fresh.v) and called.sigma_min == fresh.sigma_min


def test_a_solver_built_after_a_potential_changed_in_place_reads_it(rng):
    """Regression (issue 30): after ``potential.weights[:] *= 50`` a solver built next returns the NEW velocity (a
    hidden cache of solvers used to return the old one until it was cleared)."""
    robot, task = hoang_setup()
    potential = uvms.tasks.MidRangePotential(robot)
    q = robot.random_configuration(rng)
    before = CLIKSolver(robot, task, potential=potential, alpha=10.0).velocity(Configuration(robot, q))
    potential.weights[:] *= 50
    solver = CLIKSolver(robot, task, potential=potential, alpha=10.0)
    after = solver.velocity(Configuration(robot, q))
    expected = CLIKSolver(robot, task, potential=potential.__class__(robot, weights=potential.weights.copy()),
                          alpha=10.0).velocity(Configuration(robot, q))  # built with the new weights
    assert np.array_equal(after.v, expected.v)
    assert not np.allclose(after.v, before.v)  # the null-space motion is 50 times larger: a new velocity
    configuration = Configuration(robot, q)
    solver.step(configuration, 0.01)
    assert np.array_equal(configuration.q, pin.integrate(robot.model, q, expected.v * 0.01))


def test_a_clik_loop_keeping_its_solver_equals_a_solver_built_at_every_step(rng):
    robot, task = hoang_setup()
    potential = uvms.tasks.MidRangePotential(robot)
    options = dict(gain=1.0, weights=[1, 1, 1, 100, 100, 100], potential=potential, alpha=10.0)
    solver = CLIKSolver(robot, task, **options)
    q = robot.random_configuration(rng)
    stepped = Configuration(robot, q)
    for _ in range(20):
        q = pin.integrate(robot.model, q, solver.velocity(Configuration(robot, q)).v * 0.01)
        CLIKSolver(robot, task, **options).step(stepped, 0.01)
        assert np.array_equal(q, stepped.q)


def test_refusals_come_at_construction_and_any_iterable_of_tasks_is_read(rng):
    robot, task = hoang_setup()
    q = robot.random_configuration(rng)
    for _ in range(2):  # refused at every construction, with its message
        with pytest.raises(uvms.errors.SolverInputError, match="gain must be"):
            CLIKSolver(robot, task, gain=-1.0)
    tasks = (t for t in [task])  # a generator, read once by the solver
    assert np.array_equal(CLIKSolver(robot, tasks).velocity(Configuration(robot, q)).v,
                          CLIKSolver(robot, [task]).velocity(Configuration(robot, q)).v)
    assert np.array_equal(CLIKSolver(robot, [[task]]).velocity(Configuration(robot, q)).v,
                          CLIKSolver(robot, task).velocity(Configuration(robot, q)).v)  # levels are stacked


# ------------------------------------------------------------------ the pose hot path: CLIK on a FrameTask
def test_pose_clik_is_clik_on_a_frame_task(rng):
    """The former PoseCLIK (its own kernel) was this law: v = J^+ (xdot_d + K e) + (I - J^+ J) z0 with the DLS
    inverse of the 6-row world-aligned frame Jacobian and the log3 pose error. Its tests: one solver, its task's
    target moved, equals a solver built for that target; 300 steps reach a pose to 1e-10."""
    robot = uvms.load(uvms.model.example_robot_urdf("ur5"), base="floating")
    potential = uvms.tasks.MidRangePotential(robot)
    for alpha, twist in ((0.0, None), (2.0, rng.normal(size=6))):
        task = uvms.FrameTask(robot, axes=uvms.robot.conventions.AXIS_NAMES, orientation="log")
        hot = CLIKSolver(robot, task, gain=1.5, damping=1e-3, potential=potential, alpha=alpha)
        for _ in range(10):
            q = robot.random_configuration(rng)
            target = robot.fk(robot.random_configuration(rng))
            task.set_target(target)
            task.set_target_velocity(np.zeros(6) if twist is None else twist)
            fresh_task = uvms.FrameTask(robot, target=target)
            if twist is not None:
                fresh_task.set_target_velocity(twist)
            general = CLIKSolver(robot, fresh_task, gain=1.5, damping=1e-3, potential=potential,
                                 alpha=alpha).velocity(Configuration(robot, q))
            result = hot.velocity(Configuration(robot, q))
            assert np.allclose(result.v, general.v, atol=1e-12, rtol=1e-10)
            assert np.allclose(result.error, general.error, atol=1e-14)
    task = uvms.FrameTask(robot, orientation="log")
    hot = CLIKSolver(robot, task, gain=2.0, damping=1e-9)
    q = robot.random_configuration(rng)
    task.set_target(robot.fk(q) * pin.SE3(pin.rpy.rpyToMatrix(0.2, 0.1, -0.1), np.array([0.1, -0.1, 0.05])))
    configuration = Configuration(robot, q)
    for _ in range(300):
        hot.step(configuration, 0.05)
    assert np.linalg.norm(hot.velocity(configuration).error) <= 1e-10
    with pytest.raises(uvms.errors.SolverInputError, match="damping"):
        CLIKSolver(robot, task, damping=-1.0)
    with pytest.raises(uvms.UVMSError, match="finite"):
        hot.velocity(Configuration(robot, np.full(robot.nq, np.nan)))  # never a NaN velocity


# ------------------------------------------------------------------ the prepared step of one frame task
def numpy_clik(robot, task, q, gain, weights, damping, potential, alpha):
    """v of CLIK from numpy alone: Pinocchio's frame Jacobian and pose, c = xdot_d + K e, z0 = -alpha grad S, and
    v = L^-T A^T (A A^T + l^2 I)^-1 (c - J z0) + z0 with A = J L^-T (W = L L^T; l = 0: A^+ by numpy's SVD).
    Returns (v, sigma_min of A, J, c)."""
    data = robot.model.createData()
    pin.computeJointJacobians(robot.model, data, q)
    pin.updateFramePlacements(robot.model, data)
    jacobian = pin.getFrameJacobian(robot.model, data, task.frame_id, pin.LOCAL_WORLD_ALIGNED)[task.rows]
    pose = data.oMf[task.frame_id]
    error = np.concatenate([task.target.translation - pose.translation,
                            pin.log3(task.target.rotation @ pose.rotation.T)])[task.rows]
    command = task.target_twist[task.rows] + np.asarray(gain_matrix(gain, task.dim)) @ error
    z0 = -alpha * potential.gradient(q) if alpha else np.zeros(robot.nv)
    transform = (np.eye(robot.nv) if weights is None else np.diag(weights ** -0.5) if weights.ndim == 1
                 else np.linalg.inv(np.linalg.cholesky(weights)).T)
    scaled = jacobian @ transform
    singular = np.linalg.svd(scaled, compute_uv=False)
    if isinstance(damping, uvms.solvers.VariableDamping):
        damping = damping(singular[-1])
    inverse = (np.linalg.pinv(scaled, rcond=1e-12) if damping == 0.0 else
               scaled.T @ np.linalg.inv(scaled @ scaled.T + damping ** 2 * np.eye(task.dim)))
    return transform @ inverse @ (command - jacobian @ z0) + z0, singular[-1], jacobian, command


def gain_matrix(gain, size):
    return np.diag(np.broadcast_to(gain, (size,))) if np.ndim(gain) < 2 else gain


def test_the_prepared_frame_step_is_an_independent_numpy_clik(rng):
    """One log frame task (all axes, or some) with every kind of gain, W, damping and the null space: v is the
    numpy computation's to 1e-12 of |v|, sigma_min numpy's SVD of J L^-T, the residual |J v - c|."""
    robot = uvms.load(uvms.model.example_robot_urdf("ur5"), base="floating")
    potential = uvms.tasks.MidRangePotential(robot)
    square = rng.normal(size=(robot.nv, robot.nv))
    cases = [(None, 1.0, 1e-3, 0.0, None), (rng.uniform(0.5, 2, robot.nv), 2.0, 0.0, 1.5, None),
             (square @ square.T + robot.nv * np.eye(robot.nv), rng.uniform(0.5, 2, 6), 0.05, 1.0, None),
             (rng.uniform(0.5, 2, robot.nv), 1.0, uvms.solvers.VariableDamping(0.3, 0.2), 1.0, None),
             (None, np.diag([1.0, 2.0, 3.0]) + 0.1, 1e-2, 1.0, ("x", "y", "z")),
             (None, 1.5, 0.0, 0.0, ("x", "z", "yaw"))]
    for weights, gain, damping, alpha, axes in cases:
        task = uvms.FrameTask(robot, axes=axes, orientation="log")
        solver = CLIKSolver(robot, task, gain=gain, weights=weights, damping=damping, potential=potential,
                            alpha=alpha)
        assert solver._frame_step is not None  # the prepared path serves this solver
        for _ in range(8):
            q = robot.random_configuration(rng)
            task.set_target(robot.fk(robot.random_configuration(rng)))
            task.set_target_velocity(rng.normal(size=6))
            result = solver.velocity(Configuration(robot, q))
            v, sigma_min, jacobian, command = numpy_clik(robot, task, q, gain, weights, damping, potential, alpha)
            assert np.allclose(result.v, v, rtol=0, atol=1e-12 * max(1.0, np.abs(v).max()))
            assert result.sigma_min == pytest.approx(sigma_min, rel=1e-12)
            assert np.array_equal(result.levels[0].jacobian, jacobian)
            assert np.allclose(result.command, command, rtol=0, atol=1e-14 * np.abs(command).max())
            assert result.residual == pytest.approx(np.linalg.norm(jacobian @ result.v - result.command), abs=1e-15)


def test_the_prepared_steps_diagnostics_are_computed_when_read_and_kept_with_their_result(rng):
    """A fixed damping (Cholesky): sigma_min and the task's rows are not computed by the step; read later, after
    other steps, they are those of the step's own configuration."""
    robot = uvms.load(uvms.model.example_robot_urdf("ur5"), base="floating")
    task = uvms.FrameTask(robot, target=robot.fk(robot.random_configuration(rng)))
    solver = CLIKSolver(robot, task, gain=1.0, damping=1e-3)
    q = robot.random_configuration(rng)
    first = solver.velocity(Configuration(robot, q))
    assert "sigma_min" not in vars(first) and "levels" not in vars(first)  # not computed yet
    configuration = Configuration(robot, robot.random_configuration(rng))
    for _ in range(3):
        solver.step(configuration, 0.01)
    fresh = CLIKSolver(robot, task, gain=1.0, damping=1e-3).velocity(Configuration(robot, q))
    assert first.sigma_min == fresh.sigma_min > 0 and np.array_equal(first.error, fresh.error)
    assert np.array_equal(first.levels[0].jacobian, fresh.levels[0].jacobian) and first.residual == fresh.residual


def test_a_prepared_step_is_its_velocity_then_pin_integrate_bit_for_bit(rng):
    robot = uvms.load(uvms.model.example_robot_urdf("ur5"), base="floating")
    potential = uvms.tasks.MidRangePotential(robot)
    task = uvms.FrameTask(robot, target=robot.fk(robot.random_configuration(rng)))
    solver = CLIKSolver(robot, task, gain=2.0, weights=rng.uniform(1, 2, robot.nv), damping=1e-4,
                        potential=potential, alpha=1.0)
    q = robot.random_configuration(rng)
    configuration = Configuration(robot, q)
    for dt in (0.01, 0.05, 1):
        result = solver.step(configuration, dt)
        expected = solver.velocity(Configuration(robot, q)).v
        assert np.array_equal(result.v, expected)
        q = pin.integrate(robot.model, q, expected * dt)  # Solver.step's numbers
        assert np.array_equal(configuration.q, q)
    for dt in (0.0, -0.01, np.nan, np.inf, None):
        with pytest.raises(uvms.errors.SolverInputError, match="dt"):
            solver.step(configuration, dt)


def test_a_frame_task_on_a_mimic_joint_takes_the_general_path(rng):
    """A frame on a mimic finger: Pinocchio's data.J has a column per mimic joint, so the prepared step does not
    serve it; the general path gives the numpy CLIK of the frame's Jacobian (the mimic folded in)."""
    robot = uvms.load(MIMIC_URDF)
    task = uvms.FrameTask(robot, frame="tip_b", axes=("x", "y", "z"))
    solver = CLIKSolver(robot, task, gain=1.0, damping=1e-3)
    assert solver._frame_step is None
    for _ in range(5):
        q = robot.random_configuration(rng)
        task.set_target(robot.fk(robot.random_configuration(rng), "tip_b"))
        state = Configuration(robot, q)
        jacobian, error, _ = task.terms(state)
        expected = jacobian.T @ np.linalg.solve(jacobian @ jacobian.T + 1e-6 * np.eye(3), error)
        assert np.allclose(solver.velocity(state).v, expected, rtol=0, atol=1e-12)


MIMIC_URDF = """<robot name="mimic_probe">
  <link name="world"/>
  <joint name="base_joint" type="floating"><parent link="world"/><child link="hull"/></joint>
  <link name="hull"><inertial><mass value="10"/><inertia ixx="0.3" iyy="0.4" izz="0.5" ixy="0" ixz="0" iyz="0"/>
    </inertial></link>
  <joint name="finger_a" type="revolute"><parent link="hull"/><child link="link_a"/><origin xyz="0.4 0.05 0"/>
    <axis xyz="0 0 1"/><limit lower="-2" upper="2" effort="10" velocity="2"/></joint>
  <link name="link_a"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/>
    </inertial></link>
  <joint name="finger_b" type="revolute"><parent link="hull"/><child link="link_b"/><origin xyz="0.4 -0.05 0"/>
    <axis xyz="0 1 0"/><limit lower="-4" upper="4" effort="10" velocity="3"/>
    <mimic joint="finger_a" multiplier="-1.5" offset="0.2"/></joint>
  <link name="link_b"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/>
    </inertial></link>
  <joint name="tip_b_joint" type="fixed"><parent link="link_b"/><child link="tip_b"/><origin xyz="0.15 0 0"/></joint>
  <link name="tip_b"/>
</robot>"""


@pytest.mark.parametrize("damping", [0.0, 1e-3])
def test_the_stage_velocity_is_the_velocity_of_a_result_bit_for_bit(rng, damping):
    """What an integrator's stage reads (v alone, no result built) on the prepared frame step and on the general
    path (two tasks), over configurations and targets; a stage in between leaves the next result's lazy diagnostics
    those of its own configuration."""
    robot = uvms.load(uvms.model.example_robot_urdf("ur5"), base="floating")
    task = uvms.FrameTask(robot, target=robot.fk(robot.random_configuration(rng)))
    posture = uvms.tasks.PostureTask(robot, robot.random_configuration(rng))
    prepared = CLIKSolver(robot, task, gain=2.0, damping=damping)
    general = CLIKSolver(robot, [task, posture], gain=2.0, damping=damping)
    assert prepared._frame_step is not None and general._frame_step is None
    for _ in range(5):
        q = robot.random_configuration(rng)
        task.set_target(robot.fk(robot.random_configuration(rng)))
        task.set_target_velocity(rng.normal(size=6))
        for solver in (prepared, general):
            result = solver.velocity(Configuration(robot, q))
            other = Configuration(robot, robot.random_configuration(rng))
            staged = solver.stage_velocity(other)  # another configuration between the result and its reads
            assert np.array_equal(staged, solver.velocity(Configuration(robot, other.q)).v)
            assert np.array_equal(solver.stage_velocity(Configuration(robot, q)), result.v)
            fresh = CLIKSolver(robot, solver.tasks, gain=2.0, damping=damping).velocity(Configuration(robot, q))
            assert result.sigma_min == fresh.sigma_min and np.array_equal(result.error, fresh.error)
    with pytest.raises(uvms.errors.SolverInputError, match="Configuration"):
        prepared.stage_velocity(q)
