"""What a controller's task follows: a task and its trajectory, the task pointed at the trajectory's target of each
time once (:class:`TaskReference`), shared by the kinematic tracking controller and the actuated chain."""

from __future__ import annotations

from collections.abc import Callable

from ..tasks.frame import FrameTask
from ..trajectory import RecentSamples


class TaskReference:
    """A frame task and the trajectory it follows.

    A trajectory is a pure function of time: the same t, the same target, so the task is pointed again only when t
    changes (an integrator's stages and a controller's two solves of a step ask for the same t).

    Args:
        task: the end-effector task (any axes).
        trajectory: t [s] -> a sample with ``pose`` (pin.SE3) and ``twist`` (6,) in world axes [m/s, rad/s] (kept
            as :class:`~uvms.trajectory.recent.RecentSamples`; a trajectory table's rows are read without building
            a sample), or None: the task keeps the target it has (a controller without one holds the arm).
    """

    def __init__(self, task: FrameTask, trajectory: RecentSamples | Callable[[float], object] | None) -> None:
        self.task = task
        self.samples = (trajectory if trajectory is None or isinstance(trajectory, RecentSamples)
                        else RecentSamples(trajectory))
        self._time: float | None = None  # the time of the target the task points at

    @property
    def moving(self) -> bool:
        """Whether there is a trajectory to follow."""
        return self.samples is not None

    def follow(self, t: float) -> bool:
        """Point the task at the trajectory's pose and twist of time t [s] unless it points there already.

        Returns:
            True when the target moved (a new t); False for the same t or without a trajectory.
        """
        if self.samples is None or t == self._time:
            return False
        self.task.follow(*self.samples.target(t))
        self._time = t
        return True

    def forget(self) -> None:
        """Forget the time the task points at: the next :meth:`follow` points it again (a new run)."""
        self._time = None
