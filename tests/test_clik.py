"""CLIK (uvms.solvers.clik): a CLIKSolver built once gives the numbers of the one-call functions bit for bit, and
the one-call functions build a solver at every call, so they read the current values of their arguments."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import uvms
from uvms.solvers import CLIKSolver
from uvms.solvers.clik import solve_with_held
from uvms.robot.configuration import Configuration


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
        assert np.array_equal(uvms.clik_velocity(robot, q, task, **options).v, fresh.v)  # the one-call function
        assert np.array_equal(reused.v, fresh.v) and np.array_equal(reused.command, fresh.command)
        assert reused.sigma_min == fresh.sigma_min and reused.residual == fresh.residual
        assert np.array_equal(solver.velocity(Configuration(robot, q, check=False)), fresh.v)
        if index == 0:  # the task's own rows: the residual of an exact (undamped, full-rank) solve is rounding
            assert fresh.residual < 1e-12 and fresh.sigma_min > 0.1


def test_the_solver_path_is_the_clamping_solve_with_no_joint_held(rng):
    """The no-limit path and solve_with_held (joint clamping) are one computation: same bits, not only close."""
    robot, task = hoang_setup()
    potential = uvms.JointLimitPotential(robot)
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
            assert np.array_equal(solver.solve(state).v, held)


def test_the_prepared_gain_is_apply_gains_products(rng):
    from uvms.numerics.checks import apply_gain, prepared_gain

    error, feedforward = rng.normal(size=4), rng.normal(size=4)
    matrix = rng.normal(size=(4, 4))
    for gain in (2.5, np.array(2.5), rng.uniform(0, 3, 4), matrix @ matrix.T):
        assert np.array_equal(prepared_gain(gain, 4)(error, feedforward), feedforward + apply_gain(gain, error))
    with pytest.raises(uvms.SolverInputError, match="positive"):
        prepared_gain(-matrix @ matrix.T, 4)


# ------------------------------------------------------------------ the one-call functions build a solver per call
def test_clik_velocity_in_a_loop_gives_the_numbers_of_a_solver_built_for_each_input(rng):
    """A target moved or a W changed in place gives the numbers of a solver built afresh for those inputs."""
    robot, task = hoang_setup()
    weights = np.array([1.0, 1.0, 500.0, 1.0, 1.0, 1.0])
    for index in range(12):
        q = robot.random_configuration(rng)
        task.set_target([rng.normal(), rng.normal(), 0.0, 0.0, 0.0, rng.normal()])
        if index == 6:
            weights[2] = 3.0  # changed in place: read by the next call
        called = uvms.clik_velocity(robot, q, task, gain=1.5, weights=weights)
        fresh = CLIKSolver(robot, task, gain=1.5, weights=weights.copy()).solve(q)
        assert np.array_equal(called.v, fresh.v) and called.sigma_min == fresh.sigma_min


def test_clik_velocity_reads_a_potential_changed_in_place(rng):
    """Regression (issue 30): after ``potential.weights[:] *= 50`` the next call returns the NEW velocity (a
    hidden cache of solvers used to return the old one until it was cleared)."""
    robot, task = hoang_setup()
    potential = uvms.JointLimitPotential(robot)
    q = robot.random_configuration(rng)
    before = uvms.clik_velocity(robot, q, task, potential=potential, alpha=10.0)
    potential.weights[:] *= 50
    after = uvms.clik_velocity(robot, q, task, potential=potential, alpha=10.0)
    expected = CLIKSolver(robot, task, potential=potential, alpha=10.0).solve(q)  # built with the new weights
    assert np.array_equal(after.v, expected.v)
    assert not np.allclose(after.v, before.v)  # the null-space motion is 50 times larger: a new velocity
    step = uvms.clik_step(robot, q, task, 0.01, potential=potential, alpha=10.0)
    assert np.array_equal(step.q, pin.integrate(robot.model, q, expected.v * 0.01))


def test_a_clik_loop_keeping_its_solver_equals_clik_step_in_a_loop(rng):
    robot, task = hoang_setup()
    potential = uvms.JointLimitPotential(robot)
    options = dict(gain=1.0, weights=[1, 1, 1, 100, 100, 100], potential=potential, alpha=10.0)
    solver = CLIKSolver(robot, task, **options)
    q = stepped = robot.random_configuration(rng)
    for _ in range(20):
        q = pin.integrate(robot.model, q, solver.solve(q).v * 0.01)
        stepped = uvms.clik_step(robot, stepped, task, 0.01, **options).q
        assert np.array_equal(q, stepped)


def test_refusals_come_at_every_call_and_any_iterable_of_tasks_is_read(rng):
    robot, task = hoang_setup()
    q = robot.random_configuration(rng)
    for _ in range(2):  # refused at every call, with its message
        with pytest.raises(uvms.SolverInputError, match="gain must be"):
            uvms.clik_velocity(robot, q, task, gain=-1.0)
    tasks = (t for t in [task])  # a generator, read once by the solver built for the call
    assert np.array_equal(uvms.clik_velocity(robot, q, tasks).v, uvms.clik_velocity(robot, q, [task]).v)
