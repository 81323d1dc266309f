"""The kinematic tracking controller: a task follows a trajectory, a solver gives the velocity the robot takes."""

from __future__ import annotations

from collections.abc import Sequence

from ..dynamics.plant.command import Command, State
from ..robot.configuration import Configuration
from ..robot.robot import Robot
from ..solvers.base import SolverFactory
from ..tasks.frame import FrameTask
from ..trajectory import RecentSamples


class TrackingController:
    """The :class:`~uvms.control.base.Controller` of a kinematic run: ``Command(velocity=v, info=SolverResult)``.

    One Configuration is kept and moved to each q asked about (``update``), not one built per call.

    Args:
        robot: the model; task: the end-effector task the trajectory drives.
        samples: t -> the trajectory's sample (pose, twist), its last samples kept (RK4 stages share times).
        solver: the solver, built once here on ``levels``.
        levels: the levels, highest first; one of them holds ``task``.

    Raises:
        SolverInputError: what the solver refuses of the levels or its options.
    """

    def __init__(self, robot: Robot, task: FrameTask, samples: RecentSamples, solver: SolverFactory,
                 levels: Sequence) -> None:
        self.robot, self.task, self.samples = robot, task, samples
        self.solver = solver(levels)  # its inputs checked here, not at every evaluation
        self._time: float | None = None  # the time of the target the task points at
        self._configuration: Configuration | None = None  # built at the first call

    def reset(self, state: State, t: float = 0.0) -> None:
        """Forget the target the task points at (the configuration kept is moved at every call)."""
        self._time = None

    def follow(self, t: float) -> None:
        """Point the task at the trajectory's pose and twist of time t [s] (a trajectory is a function of time:
        the same t, the same target; a table's rows are taken without building a sample)."""
        if t != self._time:
            self.task.follow(*self.samples.target(t))
            self._time = t

    def command(self, state: State, t: float) -> Command:
        """``Command(velocity=v (nv,), info=the SolverResult: sigma_min, damping, limits_active, ...)`` at (t, q);
        the diagnostics are computed when read."""
        self.follow(t)
        q = state.q  # from pin.integrate in the one loop (checked once at its start): not validated at every call
        if self._configuration is None:
            self._configuration = Configuration(self.robot, q, check=False)
        else:
            self._configuration.update(q, check=False)
        result = self.solver.velocity(self._configuration)
        return Command(velocity=result.v, info=result)
