"""The arrays of one level's QP in the QP hierarchy (``uvms.solvers.hqp``), laid out as DAQP takes them.

One call writes the cost, the box and the rows of a level's QP over z = [x, w] (x the solved velocity (n,), w
the level's slacks (m,)), in place of about twenty numpy calls; the numbers are copies and the same
elementwise operations, so the QP is the one numpy would build, bit for bit.

The module imports numba, so it is loaded where a solver first uses it, not by ``import uvms``; its kernels
compile at their first call and are cached on disk (``cache=True``, see :mod:`uvms.numerics._kernels`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["level_qp_into", "loosened_bounds_into"]

#: DAQP's "no bound" on a one-sided row (qpsolvers' value).
NO_BOUND = 1e30


@njit(cache=True)
def loosened_bounds_into(kept: np.ndarray, tolerance: float, first: int, upper: np.ndarray) -> None:
    """upper[first + i] = kept_i + tolerance (1 + |kept_i|): the rows of the levels above, loosened."""
    for row in range(kept.size):
        upper[first + row] = kept[row] + tolerance * (1.0 + np.abs(kept[row]))


@njit(cache=True)
def level_qp_into(gram: np.ndarray, linear_x: np.ndarray, kept_rows: np.ndarray, kept: np.ndarray, tolerance: float,
                  inequality: np.ndarray, bound: np.ndarray, lower_x: np.ndarray, upper_x: np.ndarray,
                  cost: np.ndarray, linear: np.ndarray, rows: np.ndarray, upper: np.ndarray,
                  lower: np.ndarray) -> None:
    """min 1/2 z^T P z + c^T z s.t. lower <= [z; rows z] <= upper, z = [x, w], written in place.

    P = [[E^T E + r W, 0], [0, I]], c = [-E^T r_k, 0]; the box lower_x <= x <= upper_x, w >= 0; the rows
    kept_rows x <= kept + tolerance (1 + |kept|) (the levels above) and -G x - w <= -b (the level's
    inequalities G x + w >= b), one-sided (lower -1e30).

    Args:
        gram: E^T E + r W (n, n); linear_x: -E^T r_k (n,).
        kept_rows: (k, n), kept: (k,) the rows of the levels above; tolerance: their loosening.
        inequality: G (m, n); bound: b (m,).
        lower_x, upper_x: the box of x (n,).
        cost: (n + m, n + m) and rows: (k + m, n + m), zero on entry; linear: (n + m,); upper, lower:
            (n + m + k + m,); all written.
    """
    size, slacks = gram.shape[0], bound.size
    total, count = size + slacks, kept.size
    for row in range(size):
        for col in range(size):
            cost[row, col] = gram[row, col]
        linear[row] = linear_x[row]
        lower[row], upper[row] = lower_x[row], upper_x[row]
    for slack in range(slacks):
        cost[size + slack, size + slack] = 1.0
        linear[size + slack] = 0.0
        lower[size + slack], upper[size + slack] = 0.0, np.inf
    for row in range(count):
        for col in range(size):
            rows[row, col] = kept_rows[row, col]
    for row in range(slacks):
        for col in range(size):
            rows[count + row, col] = -inequality[row, col]
        rows[count + row, size + row] = -1.0
        upper[total + count + row] = -bound[row]
    loosened_bounds_into(kept, tolerance, total, upper)
    for row in range(total, total + count + slacks):
        lower[row] = -NO_BOUND
