"""The triangle of a Householder QR with column pivoting, and the few rows with the Gram matrix of many.

The set-based solver's eta rows eta^1/2 D (I - Q) (n, n) span only the directions the levels above hold
(rank r <= n): r rows F (r, n) with F^T F = P^T P give the regularized inverse the same Gram matrix
X^T A X + P^T P from a stack of m + r rows instead of m + n (``uvms.numerics._kernels.icat``).

The module imports numba, so it is loaded where a solver first uses it, not by ``import uvms``; its kernels
compile at their first call and are cached on disk (``cache=True``, see :mod:`uvms.numerics._kernels`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["gram_rows", "pivoted_triangle"]


@njit(cache=True)
def pivoted_triangle(matrix: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """R (n, n) upper triangular and the column order (n,) of A P = Q R (Householder, column pivoting), A (k, n),
    k >= n: at each step the remaining column of the largest norm comes first, so R's row norms fall and
    the rows of a rank-r A after the r-th are at its rounding level."""
    rows, size = matrix.shape
    work = matrix.copy()
    order = np.arange(size)
    reflector = np.empty(rows)
    for step in range(size):
        best, pivot = -1.0, step
        for col in range(step, size):
            norm = 0.0
            for row in range(step, rows):
                norm += work[row, col] * work[row, col]
            if norm > best:
                best, pivot = norm, col
        if pivot != step:
            for row in range(rows):
                work[row, step], work[row, pivot] = work[row, pivot], work[row, step]
            order[step], order[pivot] = order[pivot], order[step]
        if best == 0.0:
            continue  # the remaining columns are zero
        alpha = -np.sqrt(best) if work[step, step] >= 0.0 else np.sqrt(best)  # no cancellation in v_0
        length = 0.0
        for row in range(step, rows):
            reflector[row] = work[row, step]
        reflector[step] -= alpha
        for row in range(step, rows):
            length += reflector[row] * reflector[row]
        for col in range(step, size):  # (I - 2 v v^T / v^T v) on the remaining columns
            dot = 0.0
            for row in range(step, rows):
                dot += reflector[row] * work[row, col]
            dot *= 2.0 / length
            for row in range(step, rows):
                work[row, col] -= dot * reflector[row]
    upper = np.zeros((size, size))
    for row in range(size):
        for col in range(row, size):
            upper[row, col] = work[row, col]
    return upper, order


@njit(cache=True)
def gram_rows(matrix: np.ndarray, negligible: float) -> np.ndarray:
    """Rows F (r, n) with F^T F = M^T M of M (k, n), k >= n: the rows of R P^T (A P = Q R,
    :func:`pivoted_triangle`) whose squared norm is above ``negligible`` (rows at the rounding level of a stack
    count as zero in its SVD: :func:`~.svd.orthogonalize_rows`)."""
    upper, order = pivoted_triangle(matrix)
    size = upper.shape[0]
    kept = np.empty(size, dtype=np.int64)
    count = 0
    for row in range(size):
        norm = 0.0
        for col in range(row, size):
            norm += upper[row, col] * upper[row, col]
        if norm > negligible:
            kept[count] = row
            count += 1
    rows = np.zeros((count, size))
    for index in range(count):
        for col in range(size):
            rows[index, order[col]] = upper[kept[index], col]
    return rows
