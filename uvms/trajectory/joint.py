"""Joint-space trajectories: cubic and quintic polynomials through via points, ``jtraj`` and ``ctraj``.

Each segment between two via points is one polynomial per joint (xiang2019
eq. 9-17); all joints reach every via point at the same time. Via-point
velocities not given are the average of the two adjacent segment slopes (zero
at the ends); via-point accelerations of the quintic follow the same rule
applied to the via velocities. Everything is vectorized over time samples.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..errors import UVMSError
from ..numerics.validate import time_vector
from .cartesian import SE3Trajectory
from .laws import PolynomialLaw


@dataclass(frozen=True)
class JointSamples:
    """A sampled joint trajectory.

    Attributes:
        t: times (N,) [s].
        q: positions (N, n) [rad or m]; qd: velocities (N, n) [/s]; qdd: accelerations (N, n) [/s^2].
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray


@dataclass(frozen=True)
class CartesianSamples:
    """A sampled pose trajectory: times (N,) [s], poses (N SE3), twists and accelerations (N, 6) in world axes."""

    t: np.ndarray
    poses: list[pin.SE3]
    twist: np.ndarray
    acceleration: np.ndarray

    @property
    def matrices(self) -> np.ndarray:
        """The poses as homogeneous matrices (N, 4, 4)."""
        return np.array([pose.homogeneous for pose in self.poses])


def _finite_matrix(values, what: str, rows: int | None = None, columns: int | None = None) -> np.ndarray:
    """A finite float 2-D array, with the given number of rows and columns when stated."""
    array = np.array(values, dtype=float, ndmin=2)
    if array.ndim != 2 or (rows is not None and array.shape[0] != rows) or (
            columns is not None and array.shape[1] != columns):
        raise UVMSError(f"{what} must have shape ({rows or 'm'}, {columns or 'n'}), got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise UVMSError(f"{what} must be finite, got {array.tolist()}")
    return array


def check_times(times, count: int | None = None, what: str = "times") -> np.ndarray:
    """Strictly increasing finite times (m,) [s], at least two."""
    return time_vector(times, f"{what} (one per via point)" if count is not None else what, count, minimum=2)


def cubic_coefficients(q0, q1, v0, v1, duration: float) -> np.ndarray:
    """Coefficients a0..a3 (4, n) of the cubic with the given end positions and velocities (xiang2019 eq. 14)."""
    h, T = q1 - q0, duration
    return np.array([q0, v0, 3 * h / T**2 - (2 * v0 + v1) / T, -2 * h / T**3 + (v0 + v1) / T**2])


def quintic_coefficients(q0, q1, v0, v1, a0, a1, duration: float) -> np.ndarray:
    """Coefficients a0..a5 (6, n) of the quintic with end positions, velocities and accelerations (eq. 17)."""
    h, T = q1 - q0, duration
    return np.array([
        q0,
        v0,
        a0 / 2,
        (20 * h - (8 * v1 + 12 * v0) * T - (3 * a0 - a1) * T**2) / (2 * T**3),
        (-30 * h + (14 * v1 + 16 * v0) * T + (3 * a0 - 2 * a1) * T**2) / (2 * T**4),
        (12 * h - 6 * (v1 + v0) * T - (a0 - a1) * T**2) / (2 * T**5),
    ])


def evaluate_polynomials(coefficients: np.ndarray, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Value, first and second derivative of one polynomial per sample.

    Args:
        coefficients: (N, d + 1, n), lowest power first, one set per sample.
        tau: local times (N,) [s].

    Returns:
        q, qd, qdd, each (N, n).
    """
    powers = np.arange(coefficients.shape[1])
    tau = tau[:, None]
    basis = tau**powers  # (N, d + 1)
    d_basis = np.where(powers >= 1, powers * tau ** np.maximum(powers - 1, 0), 0.0)
    dd_basis = np.where(powers >= 2, powers * (powers - 1) * tau ** np.maximum(powers - 2, 0), 0.0)
    return tuple(np.einsum("nk,nkj->nj", b, coefficients) for b in (basis, d_basis, dd_basis))


def averaged_slopes(values: np.ndarray, times: np.ndarray) -> np.ndarray:
    """The via-point rule of xiang2019: mean of the two adjacent segment slopes inside, zero at the ends.

    Args:
        values: (m, n) values at the via points; times: (m,) [s].

    Returns:
        (m, n) rates [/s].
    """
    slopes = np.diff(values, axis=0) / np.diff(times)[:, None]  # (m - 1, n)
    rates = np.zeros_like(values)
    rates[1:-1] = 0.5 * (slopes[:-1] + slopes[1:])
    return rates


class ViaPointTrajectory:
    """Piecewise cubic or quintic joint trajectory through via points (xiang2019 sec. "Path planning").

    Cubic segments make positions and velocities continuous; quintic segments
    also accelerations. Via velocities default to the averaged adjacent slopes,
    via accelerations (quintic) to the averaged adjacent slopes of the via velocities.

    Args:
        points: joint values at the via points (m, n) [rad or m].
        times: arrival times (m,) [s], strictly increasing.
        degree: 3 (cubic) or 5 (quintic).
        velocities: via-point velocities (m, n) [/s], or None for the averaging rule.
        accelerations: via-point accelerations (m, n) [/s^2] (quintic only), or None for the rule.
    """

    def __init__(self, points, times, degree: int = 3, velocities=None, accelerations=None) -> None:
        if degree not in (3, 5):
            raise UVMSError(f"via-point interpolation degree must be 3 (cubic) or 5 (quintic), got {degree}")
        self.points = _finite_matrix(points, "via points")
        m, n = self.points.shape
        self.times = check_times(times, m, "via-point times")
        self.degree = degree
        self.velocities = (averaged_slopes(self.points, self.times) if velocities is None
                           else _finite_matrix(velocities, "via velocities", m, n))
        if degree == 3 and accelerations is not None:
            raise UVMSError("a cubic cannot also impose via accelerations; use degree=5")
        self.accelerations = (averaged_slopes(self.velocities, self.times) if accelerations is None
                              else _finite_matrix(accelerations, "via accelerations", m, n))
        self.coefficients = np.array([self._segment(k) for k in range(m - 1)])  # (m - 1, d + 1, n)

    def _segment(self, k: int) -> np.ndarray:
        q, v, a, T = self.points, self.velocities, self.accelerations, self.times[k + 1] - self.times[k]
        if self.degree == 3:
            return cubic_coefficients(q[k], q[k + 1], v[k], v[k + 1], T)
        return quintic_coefficients(q[k], q[k + 1], v[k], v[k + 1], a[k], a[k + 1], T)

    @property
    def duration(self) -> float:
        """Total time [s]."""
        return float(self.times[-1] - self.times[0])

    def __call__(self, t) -> JointSamples:
        """Sample at times ``t`` (scalar or (N,)) [s]; before the start and after the end the joints rest."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        clipped = np.clip(t, self.times[0], self.times[-1])
        segment = np.clip(np.searchsorted(self.times, clipped, side="right") - 1, 0, len(self.times) - 2)
        q, qd, qdd = evaluate_polynomials(self.coefficients[segment], clipped - self.times[segment])
        outside = (t < self.times[0]) | (t > self.times[-1])
        qd[outside], qdd[outside] = 0.0, 0.0
        return JointSamples(t, q, qd, qdd)

    def sample(self, step: float) -> JointSamples:
        """Sample every ``step`` [s] from the first to the last via time (both included)."""
        count = int(np.floor(self.duration / step + 1e-9)) + 1
        t = self.times[0] + step * np.arange(count)
        if t[-1] < self.times[-1] - 1e-12:
            t = np.append(t, self.times[-1])
        return self(t)


def _sample_times(steps: int | Sequence[float] | np.ndarray) -> np.ndarray:
    """N normalized times in [0, 1] for an integer, else the given time vector (shifted to start at 0)."""
    if isinstance(steps, (int, np.integer)):
        if steps < 2:
            raise UVMSError(f"the number of points must be >= 2, got {steps}")
        return np.linspace(0.0, 1.0, int(steps))
    times = check_times(steps, what="time vector")
    return times - times[0]


def jtraj(q0, q1, steps: int | Sequence[float] | np.ndarray, qd0=None, qd1=None) -> JointSamples:
    """Quintic joint trajectory from ``q0`` to ``q1`` with zero end accelerations (the toolboxes' ``jtraj``).

    Args:
        q0, q1: start and end joint values (n,).
        steps: a number of points N (time normalized to [0, 1], as the toolboxes do) or a time vector (N,) [s].
        qd0, qd1: end velocities (n,) [/s], zero by default.

    Returns:
        JointSamples with q, qd, qdd of shape (N, n).
    """
    ends = _finite_matrix([q0, q1], "jtraj end points", rows=2)
    n = ends.shape[1]
    zero = np.zeros(n)
    v0 = zero if qd0 is None else _finite_matrix(qd0, "qd0", 1, n)[0]
    v1 = zero if qd1 is None else _finite_matrix(qd1, "qd1", 1, n)[0]
    t = _sample_times(steps)
    duration = float(t[-1])
    segment = ViaPointTrajectory(ends, [0.0, duration], degree=5, velocities=[v0, v1], accelerations=[zero, zero])
    return segment(t)


def ctraj(start: pin.SE3, end: pin.SE3, steps: int | Sequence[float] | np.ndarray) -> CartesianSamples:
    """Straight-line pose trajectory with the SO(3) geodesic (slerp) and a quintic time law (``ctraj``).

    Args:
        start, end: poses in world axes.
        steps: a number of points N (time normalized to [0, 1]) or a time vector (N,) [s].

    Returns:
        CartesianSamples with N poses and their world-axes twists and accelerations (N, 6).
    """
    t = _sample_times(steps)
    motion = SE3Trajectory(start, end, PolynomialLaw(distance=1.0, duration=float(t[-1]), degree=5))
    samples = [motion(time) for time in t]
    return CartesianSamples(
        t,
        [sample.pose for sample in samples],
        np.array([sample.twist for sample in samples]),
        np.array([sample.acceleration for sample in samples]),
    )
