"""Boxes of joint positions and velocities: projection, rate bounds, saturation, scaling.

The projection of a configuration into its position limits (``uvms.solvers.ik``), the velocity bounds that
keep joints inside their limits after one step, the velocity box and the scaling of the lowest priority
levels first (``uvms.solvers.saturation``).

The module imports numba, so it is loaded where a solver first uses it, not by ``import uvms``; its kernels
compile at their first call and are cached on disk (``cache=True``, see :mod:`uvms.numerics._kernels`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["inside_box", "project_into_box", "rate_bounds_into", "saturated_sum_into", "scale_lowest_first_into",
           "speed_ratio_of", "velocity_box_into"]


@njit(cache=True)
def project_into_box(q: np.ndarray, index: np.ndarray, lower: np.ndarray, upper: np.ndarray,
                     turns: np.ndarray) -> None:
    """Bring the bounded coordinates q[index] into [lower, upper] in place.

    A revolute coordinate (``turns``) outside its limits first moves by the multiple of 2 pi that puts it
    at or above ``lower``, when that lands inside (the same pose); what is still outside is clipped.
    """
    for entry in range(index.size):
        value = q[index[entry]]
        low, high = lower[entry], upper[entry]
        if value < low or value > high:
            if turns[entry]:
                wrapped = low + np.mod(value - low, 2.0 * np.pi)
                if wrapped <= high:
                    value = wrapped
            q[index[entry]] = min(max(value, low), high)


@njit(cache=True)
def rate_bounds_into(q: np.ndarray, q_index: np.ndarray, v_index: np.ndarray, low: np.ndarray, high: np.ndarray,
                     dt: float, fraction: float, lower: np.ndarray, upper: np.ndarray) -> None:
    """Velocity bounds (nv,) that keep joints inside [low, high] after one step of ``dt`` [s].

    lower[v] = max over the rows of v of fraction (low - q) / dt, upper[v] = min of fraction (high - q) / dt;
    -inf / +inf on the entries no row bounds.

    Args:
        q: configuration (nq,); q_index, v_index: (m,) each row's coordinate in q and entry of v.
        low, high: (m,) the position limits kept; dt: the step [s] > 0; fraction: in (0, 1].
        lower, upper: (nv,) written.
    """
    lower[:] = -np.inf
    upper[:] = np.inf
    for row in range(q_index.size):
        now, entry = q[q_index[row]], v_index[row]
        lower[entry] = max(lower[entry], fraction * (low[row] - now) / dt)
        upper[entry] = min(upper[entry], fraction * (high[row] - now) / dt)


@njit(cache=True)
def velocity_box_into(maximum: np.ndarray, rate_lower: np.ndarray, rate_upper: np.ndarray, contain_zero: bool,
                      lower: np.ndarray, upper: np.ndarray) -> None:
    """The box (nv,) of rate bounds clipped into |v_i| <= maximum_i, never empty (``uvms.solvers.saturation``).

    Where two bounds disagree the tighter upper one wins; ``contain_zero`` widens the box to hold v = 0.
    """
    for entry in range(maximum.size):
        bound = maximum[entry]
        low = min(max(rate_lower[entry], -bound), bound)
        high = min(max(rate_upper[entry], -bound), bound)
        low = min(low, high)
        if contain_zero:
            low, high = min(low, 0.0), max(high, 0.0)
        lower[entry], upper[entry] = low, high


@njit(cache=True)
def inside_box(values: np.ndarray, lower: np.ndarray, upper: np.ndarray, tolerance: float) -> bool:
    """Whether lower - tolerance <= values <= upper + tolerance, entry by entry."""
    for entry in range(values.size):
        if not (values[entry] >= lower[entry] - tolerance and values[entry] <= upper[entry] + tolerance):
            return False
    return True


@njit(cache=True)
def scale_lowest_first_into(contributions: np.ndarray, lower: np.ndarray, upper: np.ndarray, tolerance: float,
                            out: np.ndarray, scales: np.ndarray) -> None:
    """sum_k s_k c_k inside the box lower <= v <= upper (which holds 0), the lowest levels scaled first.

    If the sum of the contributions c_k (L, nv) leaves the box, the lowest level is scaled by the largest
    s in [0, 1] that keeps base + s c_k inside, base the sum of the levels above; if even s = 0 does not,
    it is dropped and the next one up is scaled (``uvms.solvers.saturation``).

    Args:
        contributions: c_k (L, nv), highest priority first.
        lower, upper: the box (nv,); tolerance: the slack within which a value counts as inside.
        out: (nv,) written with the scaled sum; scales: (L,) written with the s_k.
    """
    count, size = contributions.shape
    partial = np.zeros((count + 1, size))  # partial[k]: the sum of the k highest levels
    for level in range(count):
        for entry in range(size):
            partial[level + 1, entry] = partial[level, entry] + contributions[level, entry]
    scales[:] = 1.0
    if inside_box(partial[count], lower, upper, tolerance):
        for entry in range(size):
            out[entry] = partial[count, entry]
        return
    for level in range(count - 1, -1, -1):
        scales[level] = 0.0
        base = partial[level]  # the levels above, in full
        if inside_box(base, lower, upper, tolerance):
            scale = np.inf  # the largest s with lower <= base + s c <= upper (only moving entries bound it)
            for entry in range(size):
                step = contributions[level, entry]
                if step > 0.0:
                    scale = min(scale, (upper[entry] - base[entry]) / step)
                elif step < 0.0:
                    scale = min(scale, (lower[entry] - base[entry]) / step)
            scale = min(max(scale, 0.0), 1.0)
            scales[level] = scale
            for entry in range(size):
                out[entry] = base[entry] + scale * contributions[level, entry]
            return
    out[:] = 0.0


@njit(cache=True)
def speed_ratio_of(v: np.ndarray, maximum: np.ndarray) -> float:
    """max_i |v_i| / max_i over the finite speed limits (0 without any; NaN if a ratio is NaN)."""
    largest = 0.0
    for entry in range(v.size):
        if np.isfinite(maximum[entry]):
            ratio = np.abs(v[entry]) / maximum[entry]
            if ratio > largest or ratio != ratio:
                largest = ratio
                if ratio != ratio:
                    return ratio
    return largest


@njit(cache=True)
def saturated_sum_into(solved: np.ndarray, velocities: np.ndarray, q: np.ndarray, q_index: np.ndarray,
                       v_index: np.ndarray, low: np.ndarray, high: np.ndarray, dt: float, fraction: float,
                       maximum: np.ndarray, check_inside: bool, tolerance: float, total: np.ndarray,
                       scales: np.ndarray) -> float:
    """The set-based solver's sum of its levels inside the velocity box, the lowest levels scaled first.

    The box is that of :func:`velocity_box_into` (``contain_zero``) over the speed limits ``maximum`` and the
    position-rate bounds of the rows (:func:`rate_bounds_into`; no row: none). total = c_0 + c_1 + ... in order;
    if the box bounds anything and (``check_inside`` False, or the total is outside it) the scales s_k of
    :func:`scale_lowest_first_into` on the contributions in v and total = s_0 c_0 + s_1 c_1 + ... in order.

    Args:
        solved: c_k (L, n) over the solved columns; velocities: the same in v (L, nv) (the same array unless
            free floating).
        q: configuration (nq,); q_index, v_index, low, high: the rate rows (m,); dt [s], fraction: as
            :func:`rate_bounds_into`.
        maximum: speed limits (nv,), +inf where none.
        check_inside: keep the plain sum when it is inside the box (False: always scale, free floating).
        tolerance: the slack of :func:`inside_box`.
        total: (n,) written; scales: (L,) written.

    Returns:
        :func:`speed_ratio_of` the total when it is v (n = nv; free floating: 0, v is formed after).
    """
    count, size = solved.shape
    nv = maximum.size
    lower, upper = np.empty(nv), np.empty(nv)
    if q_index.size:
        rate_bounds_into(q, q_index, v_index, low, high, dt, fraction, lower, upper)
    else:
        for entry in range(nv):
            lower[entry], upper[entry] = -np.inf, np.inf
    velocity_box_into(maximum, lower, upper, True, lower, upper)
    for level in range(count):
        scales[level] = 1.0
    for entry in range(size):
        total[entry] = solved[0, entry]
    for level in range(1, count):
        for entry in range(size):
            total[entry] += solved[level, entry]
    bounded = False
    for entry in range(nv):
        bounded = bounded or np.isfinite(lower[entry]) or np.isfinite(upper[entry])
    if bounded and not (check_inside and inside_box(total, lower, upper, tolerance)):
        out = np.empty(nv)
        scale_lowest_first_into(velocities, lower, upper, tolerance, out, scales)
        for entry in range(size):
            total[entry] = scales[0] * solved[0, entry]
        for level in range(1, count):
            for entry in range(size):
                total[entry] += scales[level] * solved[level, entry]
    return speed_ratio_of(total, maximum) if size == nv else 0.0
