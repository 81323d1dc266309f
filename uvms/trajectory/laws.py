"""Time laws s(t): how far along a path (or a fraction of a motion) at time t, with two derivatives."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import UVMSError
from ..numerics.validate import positive_number


@dataclass(frozen=True)
class LawSample:
    """s(t) [m or -], s'(t), s''(t)."""

    s: float
    ds: float
    dds: float


class TimeLaw:
    """Distance s(t) from 0 to ``distance`` over ``duration``; constant outside [0, duration]."""

    distance: float
    duration: float

    def __call__(self, t: float) -> LawSample:
        if t <= 0.0:
            return LawSample(0.0, 0.0, 0.0)
        if t >= self.duration:
            return LawSample(self.distance, 0.0, 0.0)
        return self.inside(t)

    def inside(self, t: float) -> LawSample:  # pragma: no cover - abstract
        raise NotImplementedError


def check_positive(value: float, what: str, allow_zero: bool = False) -> float:
    """A finite float > 0 (or >= 0)."""
    return positive_number(value, what, allow_zero=allow_zero)


@dataclass(frozen=True)
class TrapezoidLaw(TimeLaw):
    """Trapezoidal speed: constant acceleration for ``accel_time``, cruise, symmetric deceleration.

    Args:
        speed: cruise speed [m/s].
        duration: total time [s] (acceleration + cruise + deceleration).
        accel_time: acceleration time = deceleration time [s], 0 <= accel_time <= duration / 2.
    """

    speed: float
    duration: float
    accel_time: float = 0.0

    def __post_init__(self) -> None:
        check_positive(self.speed, "speed")
        check_positive(self.duration, "duration")
        check_positive(self.accel_time, "accel_time", allow_zero=True)
        if self.accel_time > self.duration / 2:
            raise UVMSError(f"accel_time {self.accel_time} s exceeds half the duration {self.duration} s")

    @classmethod
    def from_distance(cls, distance: float, duration: float, accel_time: float = 0.0) -> TrapezoidLaw:
        """The trapezoid covering ``distance`` [m] in ``duration`` [s]."""
        check_positive(distance, "distance")
        return cls(speed=distance / (duration - accel_time), duration=duration, accel_time=accel_time)

    @property
    def distance(self) -> float:  # type: ignore[override]
        return self.speed * (self.duration - self.accel_time)

    def inside(self, t: float) -> LawSample:
        v, ta, tf = self.speed, self.accel_time, self.duration
        if ta > 0 and t < ta:
            a = v / ta
            return LawSample(0.5 * a * t * t, a * t, a)
        if ta > 0 and t > tf - ta:
            a = v / ta
            remaining = tf - t
            return LawSample(self.distance - 0.5 * a * remaining**2, a * remaining, -a)
        return LawSample(v * (t - 0.5 * ta), v, 0.0)


@dataclass(frozen=True)
class PolynomialLaw(TimeLaw):
    """Cubic (zero end velocities) or quintic (zero end velocities and accelerations) rest-to-rest law."""

    distance: float
    duration: float
    degree: int = 5

    def __post_init__(self) -> None:
        check_positive(self.duration, "duration")
        if not np.isfinite(self.distance):
            raise UVMSError(f"distance must be finite, got {self.distance!r}")
        if self.degree not in (3, 5):
            raise UVMSError(f"polynomial time law degree must be 3 (cubic) or 5 (quintic), got {self.degree}")

    def inside(self, t: float) -> LawSample:
        tau, d, tf = t / self.duration, self.distance, self.duration
        if self.degree == 3:
            return LawSample(d * (3 * tau**2 - 2 * tau**3), d * (6 * tau - 6 * tau**2) / tf, d * (6 - 12 * tau) / tf**2)
        return LawSample(
            d * (10 * tau**3 - 15 * tau**4 + 6 * tau**5),
            d * (30 * tau**2 - 60 * tau**3 + 30 * tau**4) / tf,
            d * (60 * tau - 180 * tau**2 + 120 * tau**3) / tf**2,
        )
