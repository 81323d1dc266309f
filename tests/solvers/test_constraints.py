"""The kinematic constraint (santos2006) never diverges: a bounded command, a clear refusal where it cannot hold."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import uvms
from tests.conftest import SCENARIOS
from uvms.errors import SolverInputError, UVMSWarning
from uvms.scenario.runs import run_scenario
from uvms.solvers.constraints import ConstraintSolver
from uvms.tasks import FrameTask, VehicleTask

HELD = "vehicle.velocities={vx = 0.0, vy = 0.0, vz = 0.0, wx = 0.0, wy = 0.0, wz = 0.0}"


def test_pipe_with_the_vehicle_held_stays_bounded(tmp_path):
    """The pipe's line with the vehicle's six velocities held at 0 leaves the arm's reach: before, the undamped
    inverse of the stretched arm gave joint speeds up to 3.2e3 rad/s and joints 24.8 rad past their limits. Now the
    joints keep the model's speed limits (0.5 rad/s) and position limits, the vehicle stays put, the task error
    grows instead (recomputed from the recorded states)."""
    with warnings.catch_warnings():  # the task error above the tolerance is expected here
        warnings.simplefilter("ignore", UVMSWarning)
        run = run_scenario(SCENARIOS / "bluerov2_alpha5_pipe.toml", tmp_path / "run",
                           ["solver.method=kinematic_constraint", "solver.damping=0", "solver.weights=[]", HELD,
                            "simulation.duration=6.0", "outputs.figures=false"], progress=False)
    robot = run.setup.robot
    recorded = np.load(tmp_path / "run" / "trajectory.npz")
    q, v = recorded["q"], recorded["v"]
    speeds = np.abs(np.diff(q[:, 7:], axis=0)) / np.diff(recorded["t"])[:, None]  # arm joints, from the states
    assert speeds.max() <= 0.5 + 1e-9
    assert np.abs(v[:, 6:]).max() <= 0.5 + 1e-9
    lower, upper = robot.arm_limits
    assert np.all(q[:, 7:] >= lower - 1e-9) and np.all(q[:, 7:] <= upper + 1e-9)
    assert np.abs(q[:, :7] - q[0, :7]).max() < 1e-12  # the vehicle held
    assert 0.05 < run.metrics["max_position_error"] < 0.3  # out of reach: the error grows, it is not hidden


def held_task(robot: uvms.Robot, q: np.ndarray) -> FrameTask:
    """The jaws' position task, its target where they are."""
    task = FrameTask(robot, robot.ee_frames[0], axes=["x", "y", "z"])
    task.set_target(robot.fk(q, robot.ee_frames[0]))
    return task


def test_inconsistent_constraint_refused():
    """Constraint rows without a solution (the same velocity imposed twice with two values) are refused with the
    reason, never solved in the least-squares sense and passed on."""
    robot = uvms.load(SCENARIOS.parent / "models" / "bluerov2_alpha5" / "uvms.urdf.xacro")
    q = robot.neutral()
    both = [VehicleTask(robot, velocities={"vx": 0.1}), VehicleTask(robot, velocities={"vx": 0.3})]
    solver = ConstraintSolver(robot, [both, held_task(robot, q)])
    with pytest.raises(SolverInputError, match="inconsistent"):
        solver.velocity(uvms.Configuration(robot, q))


def test_constraint_beyond_the_speed_limits_refused():
    """A free-floating arm whose imposed rows need arm speeds beyond the model's limits (a stepped solver, given dt):
    refused, not clipped."""
    robot = uvms.load(SCENARIOS.parent / "models" / "bluerov2_alpha5" / "uvms.urdf.xacro")
    configuration = uvms.Configuration(robot, robot.neutral())
    fast = VehicleTask(robot, velocities={"wz": 5.0})  # 5 rad/s of yaw from the arm's reaction alone
    solver = ConstraintSolver(robot, [fast, held_task(robot, configuration.q)], free_floating=True, dt=0.02)
    with pytest.raises(SolverInputError, match="limit velocity"):
        solver.velocity(configuration)
