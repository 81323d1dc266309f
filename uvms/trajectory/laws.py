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

    def at(self, times: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(s, s', s'') (N,) each at the times (N,) [s]: the numbers of one call per time (a law may compute them
        all at once in the same operations)."""
        samples = [self(t) for t in times.tolist()]
        return (np.array([sample.s for sample in samples], dtype=float),
                np.array([sample.ds for sample in samples], dtype=float),
                np.array([sample.dds for sample in samples], dtype=float))


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

    def at(self, times: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(s, s', s'') (N,) each at the times (N,) [s], each phase's entries in the operations of
        :meth:`__call__` (a run's table of a few 10,000 times: one pass, not a call per time)."""
        times = np.asarray(times, dtype=float)
        if times.size < 8:  # a sample or a few: a call each costs less than the masks
            return super().at(times)
        v, ta, tf = self.speed, self.accel_time, self.duration
        s, ds, dds = np.zeros(times.shape), np.zeros(times.shape), np.zeros(times.shape)
        after, inside = times >= tf, (times > 0.0) & (times < tf)
        s[after] = self.distance
        accelerating = inside & (times < ta) if ta > 0 else np.zeros(times.shape, dtype=bool)
        decelerating = inside & ~accelerating & (times > tf - ta) if ta > 0 else accelerating
        cruising = inside & ~accelerating & ~decelerating
        if ta > 0:
            a = v / ta
            t = times[accelerating]
            s[accelerating], ds[accelerating], dds[accelerating] = 0.5 * a * t * t, a * t, a
            remaining = tf - times[decelerating]
            # Python's power of each float, as __call__ (pow(x, 2) and x * x differ in the last bit now and then)
            squared = np.array([value**2 for value in remaining.tolist()], dtype=float)
            s[decelerating], ds[decelerating], dds[decelerating] = self.distance - 0.5 * a * squared, a * remaining, -a
        s[cruising], ds[cruising] = v * (times[cruising] - 0.5 * ta), v
        return s, ds, dds


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
