"""A trajectory that remembers its last samples: an integrator asks for the same times more than once."""

from __future__ import annotations

from collections.abc import Callable
from typing import Generic, TypeVar

from .table import Target, sample_target

Sample = TypeVar("Sample")


class RecentSamples(Generic[Sample]):
    """t -> trajectory(t), the last ``size`` samples kept and returned again for the same t.

    A trajectory is a pure function of time, so a repeated t gets the same sample object. RK4 asks for
    t + dt/2 twice in a step and for t + dt again at the start of the next one: two evaluations per step
    instead of four.

    Args:
        trajectory: t [s] -> sample; size: how many samples to keep (>= 1).
    """

    def __init__(self, trajectory: Callable[[float], Sample], size: int = 3) -> None:
        self.trajectory, self.size = trajectory, size
        self._samples: dict[float, Sample] = {}
        self._target = getattr(trajectory, "target", None)  # a TrajectoryTable's rows

    def __call__(self, t: float) -> Sample:
        sample = self._samples.get(t)
        if sample is None:
            if len(self._samples) >= self.size:
                del self._samples[next(iter(self._samples))]  # the oldest
            sample = self._samples[t] = self.trajectory(t)
        return sample

    def target(self, t: float) -> Target:
        """The arrays of the pose sample's target at t [s]: the trajectory's own ``target`` when it has one (a
        :class:`~uvms.trajectory.table.TrajectoryTable`: no sample built), else read from :meth:`__call__`'s
        sample."""
        if self._target is not None:
            return self._target(t)
        return sample_target(self(t))  # type: ignore[arg-type]
