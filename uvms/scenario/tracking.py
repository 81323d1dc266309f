"""The controller of a kinematic scenario: its task follows the trajectory and the scenario's solver gives v."""

from __future__ import annotations

import numpy as np

from ..robot.configuration import Configuration
from ..robot.robot import Robot
from ..solvers import Solver, SolverResult
from ..tasks.frame import FrameTask
from ..trajectory import RecentSamples


class TrackingController:
    """(t, q, v=None) -> (v, diagnostics), the order of every controller; ``velocity(t, q)`` gives v alone.

    One Configuration is kept and moved to each q asked about (``update``), not one built per call.

    Args:
        robot: the model; task: the end-effector task the trajectory drives.
        samples: t -> the trajectory's sample (pose, twist), its last samples kept (RK4 stages share times).
        solver: the scenario's solver, built once on the levels that hold ``task``.
    """

    def __init__(self, robot: Robot, task: FrameTask, samples: RecentSamples, solver: Solver) -> None:
        self.robot, self.task, self.samples, self.solver = robot, task, samples, solver
        self._current = None  # the sample the task points at
        self._configuration: Configuration | None = None  # built at the first call

    def follow(self, t: float) -> None:
        """Point the task at the trajectory's pose and twist of time t [s]."""
        sample = self.samples(t)
        if sample is not self._current:
            self.task.set_target(sample.pose)
            self.task.set_target_velocity(sample.twist, check=False)  # a trajectory's sample: finite, (6,)
            self._current = sample

    def _solve(self, t: float, q: np.ndarray) -> SolverResult:
        self.follow(t)
        # q comes from pin.integrate in the one loop (checked once at its start): not validated at every call
        if self._configuration is None:
            self._configuration = Configuration(self.robot, q, check=False)
        else:
            self._configuration.update(q, check=False)
        return self.solver.velocity(self._configuration)

    def __call__(self, t: float, q: np.ndarray, v: np.ndarray | None = None) -> tuple[np.ndarray, SolverResult]:
        """(v (nv,), the SolverResult: sigma_min, damping, limits_active, ...) at (t, q)."""
        result = self._solve(t, q)
        return result.v, result

    def velocity(self, t: float, q: np.ndarray) -> np.ndarray:
        """v (nv,) at (t, q): what an integrator's inner stages need (the diagnostics are computed when read)."""
        return self._solve(t, q).v
