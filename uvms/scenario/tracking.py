"""The controller of a kinematic scenario: its task follows the trajectory and the solver method gives v."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..robot.robot import Robot
from ..robot.configuration import Configuration
from ..tasks.frame import FrameTask
from ..trajectory import RecentSamples

#: The solver of a scenario: the state (the task pointed at its target) -> a result with v (nv,) and diagnostics.
Solve = Callable[[Configuration], object]


class TrackingController:
    """(t, q, v=None) -> (v, diagnostics), the order of every controller; ``velocity(t, q)`` gives v alone.

    Args:
        robot: the model; task: the end-effector task the trajectory drives.
        samples: t -> the trajectory's sample (pose, twist), its last samples kept (RK4 stages share times).
        solve: the state -> the solver's result (``v``, sigma_min, damping...).
        velocity: the state -> v (nv,) alone, where the solver has a cheaper form without diagnostics
            (None: ``solve(state).v``).
    """

    def __init__(self, robot: Robot, task: FrameTask, samples: RecentSamples, solve: Solve,
                 velocity: Callable[[Configuration], np.ndarray] | None = None) -> None:
        self.robot, self.task, self.samples = robot, task, samples
        self._solve, self._velocity = solve, velocity
        self._current = None  # the sample the task points at

    def follow(self, t: float) -> None:
        """Point the task at the trajectory's pose and twist of time t [s]."""
        sample = self.samples(t)
        if sample is not self._current:
            self.task.set_target(sample.pose)
            self.task.set_target_velocity(sample.twist, check=False)  # a trajectory's sample: finite, (6,)
            self._current = sample

    def _state(self, t: float, q: np.ndarray) -> Configuration:
        self.follow(t)
        # q comes from pin.integrate in the one loop (checked once at its start): not validated at every call
        return Configuration(self.robot, q, check=False)

    def __call__(self, t: float, q: np.ndarray, v: np.ndarray | None = None) -> tuple[np.ndarray, object]:
        result = self._solve(self._state(t, q))
        return result.v, result

    def velocity(self, t: float, q: np.ndarray) -> np.ndarray:
        """v (nv,) at (t, q) without the diagnostics: what an integrator's inner stages need."""
        state = self._state(t, q)
        return self._velocity(state) if self._velocity is not None else self._solve(state).v
