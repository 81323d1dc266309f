"""A trajectory that remembers its last samples: an integrator asks for the same times more than once."""

from __future__ import annotations

from collections.abc import Callable
from typing import Generic, TypeVar

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

    def __call__(self, t: float) -> Sample:
        sample = self._samples.get(t)
        if sample is None:
            if len(self._samples) >= self.size:
                del self._samples[next(iter(self._samples))]  # the oldest
            sample = self._samples[t] = self.trajectory(t)
        return sample
