"""A trajectory evaluated once at the times a fixed-step run asks for: the controller's and recorder's samples."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from .cartesian import PoseSample


class TrajectoryTable:
    """t -> the trajectory's sample, the times of a run (its integrator's stages) evaluated in one call.

    A trajectory with ``at(times) -> PoseSamples`` (:class:`~uvms.trajectory.cartesian.PathTrajectory`) is
    evaluated over all the times at once, its numbers those of one call per time; a time not in the table, or a
    trajectory without ``at``, is evaluated when asked for.

    Args:
        trajectory: t [s] -> PoseSample, with ``duration`` [s].
        times: the times [s] the run will ask for, as its loop computes them
            (:func:`uvms.numerics.integrate.stage_times`).
    """

    def __init__(self, trajectory: Callable[[float], PoseSample], times: Sequence[float]) -> None:
        self.trajectory = trajectory
        self.duration = trajectory.duration  # type: ignore[attr-defined]
        at = getattr(trajectory, "at", None)
        times = list(dict.fromkeys(times)) if at is not None else []
        self._samples = at(np.array(times, dtype=float)) if times else None
        self._rows = {t: row for row, t in enumerate(times)}

    def __call__(self, t: float) -> PoseSample:
        row = self._rows.get(t)
        return self.trajectory(t) if row is None else self._samples.sample(row)  # type: ignore[union-attr]
