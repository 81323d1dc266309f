"""Velocity bounds that keep the priority order: the lowest levels are scaled first.

The bounds are a box lower <= v <= upper on the entries of v (nv,), from

* speed limits |v_i| <= max_i (:class:`~uvms.tasks.objectives.VelocityLimit`), and
* position limits turned into rate bounds over one step: fraction (q_min - q_i) / dt <= v_i <=
  fraction (q_max - q_i) / dt (:class:`~uvms.tasks.objectives.JointLimits`),

clipped into the speed limits, so the box is never empty: started outside a position limit, the joint
must come back at the allowed speed (the rate bound min(fraction (q_min - q) / dt, max) stays reachable).

A hierarchy's velocity is the sum of its levels' contributions v = sum_k c_k. :func:`scale_lowest_first`
meets the box by the per-level task scaling of the saturation literature (Flacco, De Luca and Khatib,
"Control of redundant robots under hard joint constraints: saturation in the null space", IEEE T-RO 2015,
in its simpler per-level form): if the sum leaves the box, the lowest level's contribution is scaled by
the largest s in [0, 1] that brings it back; if even s = 0 does not, that level is dropped and the next
one up is scaled, and so on. A box that contains 0 always admits a solution (every s = 0).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..tasks.objectives import JointLimits, VelocityLimit

#: Slack [m/s or rad/s] within which a velocity on the wrong side of a bound counts as inside.
TOLERANCE = 1e-12


def speed_maximum(nv: int, limits: Sequence[VelocityLimit]) -> np.ndarray:
    """The tightest speed limit of each entry of v (nv,) [m/s, rad/s]; +inf where none applies."""
    maximum = np.full(nv, np.inf)
    for limit in limits:
        maximum = np.minimum(maximum, limit.maximum)
    return maximum


def position_rate_bounds(q: np.ndarray, nv: int, joint_limits: Sequence[JointLimits], dt: float,
                         fraction: float = 1.0, valid_set: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Velocity bounds (nv,), (nv,) that keep joints inside their limits after one step of ``dt`` [s].

    Args:
        q: configuration (nq,).
        nv: size of v.
        joint_limits: the joint-limit objectives whose limits are kept (their rows' joints).
        dt: step [s] > 0.
        fraction: the part of the distance to a limit that one step may cover, in (0, 1].
        valid_set: keep the valid set (the limits moved in by the margin) instead of the model's limits.

    Returns:
        (lower, upper), -inf / +inf on the entries no objective limits.
    """
    lower, upper = np.full(nv, -np.inf), np.full(nv, np.inf)  # (nv,) each
    for objective in joint_limits:
        low, high = (objective.lower, objective.upper) if valid_set else (objective.hard_lower, objective.hard_upper)
        now = q[objective.q_index]
        index = objective.v_index
        lower[index] = np.maximum(lower[index], fraction * (low - now) / dt)
        upper[index] = np.minimum(upper[index], fraction * (high - now) / dt)
    return lower, upper


def velocity_box(maximum: np.ndarray, rate_lower: np.ndarray, rate_upper: np.ndarray,
                 contain_zero: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """The box (lower, upper) (nv,): rate bounds clipped into |v_i| <= maximum_i, never empty.

    Args:
        maximum: speed limits (nv,), +inf where none.
        rate_lower, rate_upper: position-rate bounds (nv,) (:func:`position_rate_bounds`).
        contain_zero: also widen the box to hold v = 0 (what scaling needs; a joint outside its limit is
            then stopped, not pushed further out, and its objective brings it back).
    """
    lower = np.minimum(np.maximum(rate_lower, -maximum), maximum)  # np.clip's numbers, a third of its cost
    upper = np.minimum(np.maximum(rate_upper, -maximum), maximum)
    lower = np.minimum(lower, upper)  # only when two objectives disagree; the tighter upper bound wins
    if contain_zero:
        lower, upper = np.minimum(lower, 0.0), np.maximum(upper, 0.0)
    return lower, upper


def inside(values: np.ndarray, lower: np.ndarray, upper: np.ndarray, tolerance: float = TOLERANCE) -> bool:
    """Whether lower <= values <= upper, up to ``tolerance``."""
    return bool((values >= lower - tolerance).all() and (values <= upper + tolerance).all())


def largest_scale(base: np.ndarray, step: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> float:
    """The largest s in [0, 1] with lower <= base + s step <= upper, for ``base`` inside the box."""
    rising, falling = step > 0, step < 0  # only these entries bound s (a zero step never leaves the box)
    up = (upper[rising] - base[rising]) / step[rising]
    down = (lower[falling] - base[falling]) / step[falling]
    return float(min(max(min(up.min(initial=np.inf), down.min(initial=np.inf)), 0.0), 1.0))


def scale_lowest_first(contributions: Sequence[np.ndarray], lower: np.ndarray,
                       upper: np.ndarray) -> tuple[np.ndarray, tuple[float, ...]]:
    """sum_k s_k c_k inside the box, the lowest levels scaled first.

    Args:
        contributions: c_k (nv,) per level, highest priority first.
        lower, upper: the box (nv,); it must contain 0 (:func:`velocity_box` with ``contain_zero``).

    Returns:
        (the scaled sum (nv,), the scales s_k).
    """
    count = len(contributions)
    partial = [np.zeros_like(lower)]
    for contribution in contributions:
        partial.append(partial[-1] + contribution)
    if inside(partial[-1], lower, upper):
        return partial[-1], (1.0,) * count
    for level in range(count - 1, -1, -1):
        base = partial[level]  # the levels above, in full
        if inside(base, lower, upper):
            scale = largest_scale(base, contributions[level], lower, upper)
            return base + scale * contributions[level], (1.0,) * level + (scale,) + (0.0,) * (count - level - 1)
    return partial[0], (0.0,) * count
