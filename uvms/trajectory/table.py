"""A trajectory evaluated once at the times a fixed-step run asks for: the controller's and recorder's samples."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import pinocchio as pin

from .cartesian import PoseSample

#: A target as a task takes it: translation (3,) [m], rotation (3, 3), twist (6,) [m/s, rad/s], rpy (3,) [rad]
#: or None (not known: the task computes it).
Target = tuple[np.ndarray, np.ndarray, np.ndarray, "np.ndarray | None"]


def sample_target(sample: PoseSample) -> Target:
    """The arrays of a sample's target (its pose read once; rpy left to the task)."""
    pose = sample.pose
    return pose.translation, pose.rotation, sample.twist, None


def twists_at(trajectory: Callable[[float], PoseSample], times: np.ndarray) -> np.ndarray:
    """The trajectory's twists [v; omega] (N, 6) [m/s, rad/s] at the times (N,) [s]: in one call over all of them
    where it has ``at(times) -> PoseSamples`` (the numbers of one call per time), else one call per time."""
    at = getattr(trajectory, "at", None)
    if at is not None:
        return at(np.asarray(times, dtype=float)).twists
    return np.array([trajectory(float(t)).twist for t in times]).reshape(-1, 6)


def pose_function(trajectory: Callable[[float], PoseSample]) -> Callable[[float], pin.SE3]:
    """t [s] -> the trajectory's pose (``pin.SE3``, world): made from its ``target`` arrays where it has them (a
    table's row: no sample built, ~2 us instead of ~9 for a run's task series), else its sample's pose; the same
    numbers either way."""
    target = getattr(trajectory, "target", None)
    if target is None:
        return lambda t: trajectory(t).pose
    se3 = pin.SE3

    def pose(t: float) -> pin.SE3:
        translation, rotation, _, _ = target(t)
        return se3(rotation, translation)

    return pose


class TrajectoryTable:
    """t -> the trajectory's sample, the times of a run (its integrator's stages) evaluated in one call.

    A trajectory with ``at(times) -> PoseSamples`` (:class:`~uvms.trajectory.cartesian.PathTrajectory`) is
    evaluated over all the times at once, its numbers those of one call per time; a time not in the table, or a
    trajectory without ``at``, is evaluated when asked for. :meth:`target` gives a row's arrays without building
    a sample or a ``pin.SE3`` (what a controller's task follows at every integrator stage).

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
        self._samples = samples = at(np.array(times, dtype=float)) if times else None
        self._rows = {t: row for row, t in enumerate(times)}
        if samples is not None:  # the table's own copies, in a pose's layout: what a compiled step takes of a target
            def copy(array: np.ndarray) -> np.ndarray:  # writeable and row-major, whatever the input's strides
                return np.array(array, order="C")

            self._translations, self._twists, self._rpy = (copy(samples.translations), copy(samples.twists),
                                                           copy(samples.rpy))
            self._rotations = copy(samples.rotations.transpose(0, 2, 1)).transpose(0, 2, 1)  # rows F-ordered

    def __call__(self, t: float) -> PoseSample:
        row = self._rows.get(t)
        return self.trajectory(t) if row is None else self._samples.sample(row)  # type: ignore[union-attr]

    def target(self, t: float) -> Target:
        """(translation (3,) [m], rotation (3, 3), twist (6,), rpy (3,) [rad]) at t [s]: a row's views of the
        table's own arrays (never to be written), or read from the trajectory's sample at a time not tabled
        (rpy None)."""
        row = self._rows.get(t)
        if row is None:
            return sample_target(self.trajectory(t))
        return self._translations[row], self._rotations[row], self._twists[row], self._rpy[row]
