"""Velocity ramps: an end-effector reference whose velocity is piecewise linear (amundsen2018 sec. III, eq. 9-11)."""

from __future__ import annotations

import bisect
from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from ..errors import GJMControlError
from .cartesian import PoseSample


class VelocityRamps:
    """End-effector reference from velocity ramps: v(t) piecewise linear, p(t) its exact integral.

    v(t) is linear between the knots (times[k], velocities[k]) and constant
    outside them; p(t) = start + integral of v from times[0]. The orientation of
    the desired pose is constant (``rotation``) and the desired angular velocity
    zero: this is the reference of amundsen2018 sec. III (eq. 9-11), whose
    positions are "the integrals of the velocity references".

    The acceleration at an interior knot (and at the last one) is the mean of the
    slopes on both sides, at the first knot the slope after it. A fixed-step
    integrator that lands on a ramp corner then errs by +- half the jump on the
    two sides of it, which cancel (a one-sided value would leave an error of order dt).

    Args:
        start: p(times[0]) (3,) [m], world frame.
        times: knot times (K,) [s], strictly increasing, K >= 2.
        velocities: (K, 3) [m/s] at the knots, world axes.
        rotation: constant orientation of the desired pose (3, 3) (default identity).

    Raises:
        GJMControlError: wrong shapes, non-finite values, times not increasing.
    """

    def __init__(self, start: Sequence[float], times: Sequence[float], velocities: Sequence[Sequence[float]],
                 rotation: np.ndarray | None = None) -> None:
        self.start = _finite(start, (3,), "start")
        self.times = _finite(times, (None,), "times")
        self.velocities = _finite(velocities, (len(self.times), 3), "velocities")
        if len(self.times) < 2 or np.any(np.diff(self.times) <= 0):
            raise GJMControlError("times must be at least 2 strictly increasing "
                                  f"knot times [s], got {self.times.tolist()}")
        self.rotation = np.eye(3) if rotation is None else _finite(rotation, (3, 3), "rotation")
        self._knots = self.times.tolist()
        spans = np.diff(self.times)
        self.slopes = np.diff(self.velocities, axis=0) / spans[:, None]  # (K-1, 3) [m/s^2]
        areas = 0.5 * (self.velocities[1:] + self.velocities[:-1]) * spans[:, None]
        self.knot_positions = self.start + np.vstack([np.zeros(3), np.cumsum(areas, axis=0)])  # (K, 3)

    @classmethod
    def trapezoid(cls, start: Sequence[float], velocity: Sequence[float], duration: float, ramp_time: float,
                  rotation: np.ndarray | None = None) -> VelocityRamps:
        """Ramp from rest to ``velocity`` in ``ramp_time``, cruise, ramp back to rest at ``duration``.

        Args:
            start: (3,) [m]; velocity: cruise velocity (3,) [m/s], world axes.
            duration: total time [s] > 0; ramp_time: (0, duration / 2] [s].
        """
        duration, ramp_time = float(duration), float(ramp_time)
        if not (np.isfinite(duration) and duration > 0):
            raise GJMControlError(f"duration must be finite and > 0 s, got {duration!r}")
        if not (np.isfinite(ramp_time) and 0 < ramp_time <= duration / 2):
            raise GJMControlError(f"ramp_time must be in (0, duration/2] = (0, {duration / 2:g}] s, got {ramp_time!r}")
        cruise = _finite(velocity, (3,), "velocity")
        if ramp_time == duration / 2:
            return cls(start, [0.0, ramp_time, duration], [np.zeros(3), cruise, np.zeros(3)], rotation)
        return cls(start, [0.0, ramp_time, duration - ramp_time, duration],
                   [np.zeros(3), cruise, cruise, np.zeros(3)], rotation)

    @property
    def duration(self) -> float:
        """Time of the last knot [s]."""
        return float(self.times[-1])

    def _segment(self, t: float) -> int:
        """Index k of the segment [times[k], times[k+1]) that holds t (clipped to the first and last)."""
        return min(max(bisect.bisect_right(self._knots, t) - 1, 0), len(self._knots) - 2)

    def velocity(self, t: float) -> np.ndarray:
        """v_d(t) (3,) [m/s]."""
        if t <= self.times[0]:
            return self.velocities[0].copy()
        if t >= self.times[-1]:
            return self.velocities[-1].copy()
        k = self._segment(t)
        return self.velocities[k] + self.slopes[k] * (t - self.times[k])

    def position(self, t: float) -> np.ndarray:
        """p_d(t) (3,) [m]."""
        if t <= self.times[0]:
            return self.start + self.velocities[0] * (t - self.times[0])
        if t >= self.times[-1]:
            return self.knot_positions[-1] + self.velocities[-1] * (t - self.times[-1])
        k = self._segment(t)
        s = t - self.times[k]
        return self.knot_positions[k] + self.velocities[k] * s + 0.5 * self.slopes[k] * s * s

    def acceleration(self, t: float) -> np.ndarray:
        """dv_d/dt (3,) [m/s^2]; at a knot the mean of both sides (the right side at the first knot)."""
        knots, slopes = self._knots, self.slopes
        tolerance = 1e-12 * max(1.0, abs(t))
        if t < knots[0] - tolerance or t > knots[-1] + tolerance:
            return np.zeros(3)
        k = bisect.bisect_left(knots, t)  # knots[k - 1] < t <= knots[k]
        if k > 0 and (k == len(knots) or t - knots[k - 1] < knots[k] - t):
            k -= 1  # the nearer knot
        if abs(knots[k] - t) <= tolerance:  # on a knot (up to rounding of the stage times)
            if k == 0:
                return slopes[0].copy()
            after = slopes[k] if k < len(slopes) else np.zeros(3)
            return 0.5 * (slopes[k - 1] + after)
        return slopes[self._segment(t)].copy()

    def __call__(self, t: float) -> PoseSample:
        """Desired pose, twist [v; 0] (6,) and acceleration [a; 0] (6,) at t [s], world axes."""
        zeros = np.zeros(3)
        return PoseSample(pin.SE3(self.rotation, self.position(t)),
                          np.concatenate([self.velocity(t), zeros]), np.concatenate([self.acceleration(t), zeros]))


def _finite(values, shape: tuple, what: str) -> np.ndarray:
    try:
        array = np.array(values, dtype=float)
    except (TypeError, ValueError):
        raise GJMControlError(f"{what} must be numbers, got {values!r}") from None
    if array.ndim != len(shape) or any(size is not None and size != actual for size, actual in zip(shape, array.shape)):
        expected = "x".join("K" if size is None else str(size) for size in shape)
        raise GJMControlError(f"{what} must have shape ({expected}), got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise GJMControlError(f"{what} must be finite, got {array.tolist()}")
    return array
