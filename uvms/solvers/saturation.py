"""Velocity bounds that keep the priority order: the lowest levels are scaled first.

The bounds are a box lower <= v <= upper on the entries of v (nv,), from

* speed limits |v_i| <= max_i (:class:`~uvms.tasks.objectives.VelocityLimit`), and
* position limits turned into rate bounds over one step: fraction (q_min - q_i) / dt <= v_i <=
  fraction (q_max - q_i) / dt (:class:`~uvms.tasks.objectives.JointLimits`),

clipped into the speed limits, so the box is never empty: started outside a position limit, the joint
must come back at the allowed speed (the rate bound min(fraction (q_min - q) / dt, max) stays reachable).

A hierarchy's velocity is the sum of its levels' contributions v = sum_k c_k. The set-based solver meets
the box (:func:`~uvms.numerics._kernels.boxes.saturated_sum_into`, one compiled call with the box's rows) by
the per-level task scaling of the saturation literature (Flacco, De Luca and Khatib,
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


class RateRows:
    """The rows of joint-limit objectives a position-rate bound reads, stacked once (m,) each.

    Attributes:
        q_index, v_index: each row's coordinate in q and entry of v (int64).
        low, high: the position limits kept [rad or m].
    """

    def __init__(self, q_index: np.ndarray, v_index: np.ndarray, low: np.ndarray, high: np.ndarray) -> None:
        self.q_index, self.v_index, self.low, self.high = q_index, v_index, low, high

    @classmethod
    def of(cls, joint_limits: Sequence[JointLimits], valid_set: bool = False) -> RateRows:
        """The model's limits of the objectives' rows (their valid sets with ``valid_set``)."""
        def stacked(parts: list[np.ndarray], kind: type) -> np.ndarray:
            return np.concatenate(parts).astype(kind) if parts else np.zeros(0, dtype=kind)

        return cls(stacked([objective.q_index for objective in joint_limits], np.int64),
                   stacked([objective.v_index for objective in joint_limits], np.int64),
                   stacked([objective.lower if valid_set else objective.hard_lower for objective in joint_limits],
                           float),
                   stacked([objective.upper if valid_set else objective.hard_upper for objective in joint_limits],
                           float))

    def bounds(self, q: np.ndarray, nv: int, dt: float, fraction: float) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper) (nv,) at q (:func:`~uvms.numerics._kernels.boxes.rate_bounds_into`)."""
        from ..numerics._kernels.boxes import rate_bounds_into  # numba: loaded at the first use, not by ``import uvms``

        lower, upper = np.empty(nv), np.empty(nv)
        rate_bounds_into(q, self.q_index, self.v_index, self.low, self.high, dt, fraction, lower, upper)
        return lower, upper


def velocity_box(maximum: np.ndarray, rate_lower: np.ndarray, rate_upper: np.ndarray,
                 contain_zero: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """The box (lower, upper) (nv,): rate bounds clipped into |v_i| <= maximum_i, never empty.

    Args:
        maximum: speed limits (nv,), +inf where none.
        rate_lower, rate_upper: position-rate bounds (nv,) (:meth:`RateRows.bounds`).
        contain_zero: also widen the box to hold v = 0 (what scaling needs; a joint outside its limit is
            then stopped, not pushed further out, and its objective brings it back).
    """
    from ..numerics._kernels.boxes import velocity_box_into  # numba: loaded at the first use, not by ``import uvms``

    lower, upper = np.empty(maximum.size), np.empty(maximum.size)
    velocity_box_into(np.ascontiguousarray(maximum, dtype=float), np.ascontiguousarray(rate_lower, dtype=float),
                      np.ascontiguousarray(rate_upper, dtype=float), contain_zero, lower, upper)
    return lower, upper
