"""The one-sided Jacobi SVD and the damped inverse built from it (``uvms.numerics.inverses``).

The variable damping of amundsen2018 eq. 6, the Hestenes rotation of rows until they are orthogonal, the
decomposition A = G^T B as the inverses need it (singular values, cut-off, damping) and the DLS inverse
V diag(s / (s^2 + l^2)) U^T written into a preallocated array.

The module imports numba, so it is loaded where a solver first uses it, not by ``import uvms``; its kernels
compile at their first call and are cached on disk (``cache=True``, see :mod:`uvms.numerics._kernels`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

#: Sweeps after which a one-sided Jacobi SVD that has not converged is refused (finite input needs about six).
JACOBI_SWEEPS = 64
EPSILON = np.finfo(np.float64).eps

__all__ = ["JACOBI_SWEEPS", "decompose", "orthogonalize_rows", "squared_norm", "svd_inverse_into",
           "variable_damping_value", "zero_negligible_row"]


@njit(cache=True)
def variable_damping_value(sigma_min: float, epsilon: float, lambda_max: float) -> float:
    """Damping l of amundsen2018 eq. 6: l^2 = (1 - (sigma_min / epsilon)^2) lambda_max^2 below epsilon, else 0."""
    if sigma_min >= epsilon:
        return 0.0
    return np.sqrt(1.0 - (sigma_min / epsilon) ** 2) * lambda_max


@njit(cache=True)
def zero_negligible_row(rows: np.ndarray, row: int) -> None:
    """Set row ``row`` of B to exact zeros (its norm is at the rounding level of the matrix)."""
    for col in range(rows.shape[1]):
        rows[row, col] = 0.0


@njit(cache=True)
def squared_norm(rows: np.ndarray, row: int) -> float:
    """|b_row|^2 of row ``row`` of B, summed in column order."""
    total = 0.0
    for col in range(rows.shape[1]):
        total += rows[row, col] * rows[row, col]
    return total


@njit(cache=True)
def orthogonalize_rows(rows: np.ndarray, rotation: np.ndarray) -> bool:
    """One-sided (Hestenes) Jacobi SVD: rotate the rows of B (k, n) in place until they are mutually orthogonal.

    On return B_out = G B_in with G (k, k) orthogonal (written to ``rotation``): the row norms of B_out are the
    singular values and B_in = G^T B_out. Pairs are rotated until |b_i . b_j| <= n eps |b_i| |b_j|, which gives
    the singular values to high relative accuracy (Demmel and Veselic 1992). A row whose norm falls to the
    rounding level of the matrix (n eps |B|_F) is set to zero: its direction is noise that no rotation can
    make orthogonal, and its singular value is zero to working precision.

    Returns:
        False when the rows are not orthogonal after ``JACOBI_SWEEPS`` sweeps (non-finite input).
    """
    count, length = rows.shape
    for row in range(count):
        for col in range(count):
            rotation[row, col] = 1.0 if row == col else 0.0
    tolerance = length * EPSILON
    frobenius_squared = 0.0
    for row in range(count):
        for col in range(length):
            frobenius_squared += rows[row, col] * rows[row, col]
    if frobenius_squared != frobenius_squared or frobenius_squared == np.inf:  # NaN or an infinite entry
        return False
    negligible = tolerance * tolerance * frobenius_squared  # a squared row norm at the rounding level
    # squared row norms, each summed again only after its row was rotated (the same sums: a row left alone
    # keeps its norm, so the late sweeps, which rotate few pairs, compute one product per pair instead of three)
    norms = np.empty(count)
    fresh = np.zeros(count, dtype=np.bool_)
    for _ in range(JACOBI_SWEEPS):
        rotated = False
        for first in range(count - 1):
            for second in range(first + 1, count):
                for row in (first, second):
                    if not fresh[row]:
                        norms[row] = squared_norm(rows, row)
                        fresh[row] = True
                alpha, beta = norms[first], norms[second]
                if alpha <= negligible or beta <= negligible:
                    row = first if alpha <= negligible else second
                    zero_negligible_row(rows, row)
                    norms[row] = 0.0
                    continue
                gamma = 0.0
                for col in range(length):
                    gamma += rows[first, col] * rows[second, col]
                if not abs(gamma) > tolerance * np.sqrt(alpha) * np.sqrt(beta):
                    continue
                rotated = True
                fresh[first] = fresh[second] = False
                zeta = (beta - alpha) / (2.0 * gamma)
                tangent = (1.0 if zeta >= 0.0 else -1.0) / (abs(zeta) + np.sqrt(1.0 + zeta * zeta))
                cosine = 1.0 / np.sqrt(1.0 + tangent * tangent)
                sine = cosine * tangent
                for col in range(length):
                    a, b = rows[first, col], rows[second, col]
                    rows[first, col] = cosine * a - sine * b
                    rows[second, col] = sine * a + cosine * b
                for col in range(count):
                    a, b = rotation[first, col], rotation[second, col]
                    rotation[first, col] = cosine * a - sine * b
                    rotation[second, col] = sine * a + cosine * b
        if not rotated:
            return True
    return False


@njit(cache=True)
def decompose(matrix: np.ndarray, damping: float, epsilon: float, lambda_max: float, rcond: float,
              floor: float):
    """The SVD of A (k, n) as the inverse needs it: (converged, wide, B, G, factors, sigma_min, l used).

    B = G A (rows s_i v_i^T) when k <= n (``wide``), else B = G A^T (rows s_i u_i^T); factors (m,) are
    1 / (s_i^2 + l^2), or with l = 0 1 / s_i^2 above rcond * s_max and 0 below, and 0 for s_i <= ``floor`` (an
    absolute noise level, 0: none), so that
    A^+ = B^T diag(factors) G (wide) or G^T diag(factors) B (tall): right^T diag(factors) left. sigma_min is 0
    when k > n; l is the fixed ``damping``, or the variable damping of sigma_min when ``epsilon`` > 0.
    """
    rows, columns = matrix.shape
    wide = rows <= columns
    work = matrix.copy() if wide else matrix.T.copy()  # (m, p), m <= p
    count, length = work.shape
    rotation = np.empty((count, count))
    factors = np.zeros(count)
    if not orthogonalize_rows(work, rotation):
        return False, wide, work, rotation, factors, np.nan, np.nan
    singular = np.empty(count)
    largest, smallest = 0.0, np.inf
    for row in range(count):
        value = 0.0
        for col in range(length):
            value += work[row, col] * work[row, col]
        singular[row] = np.sqrt(value)
        largest = max(largest, singular[row])
        smallest = min(smallest, singular[row])
    sigma_min = smallest if wide and count > 0 else 0.0
    used = variable_damping_value(sigma_min, epsilon, lambda_max) if epsilon > 0.0 else damping
    for row in range(count):
        if singular[row] <= floor and floor > 0.0:
            continue  # rounding noise: its direction is no direction
        if used > 0.0:
            factors[row] = 1.0 / (singular[row] * singular[row] + used * used)
        elif singular[row] > rcond * largest:
            factors[row] = 1.0 / (singular[row] * singular[row])
    return True, wide, work, rotation, factors, sigma_min, used


@njit(cache=True)
def svd_inverse_into(jacobian: np.ndarray, damping: float, epsilon: float, lambda_max: float, rcond: float,
                     floor: float, out: np.ndarray) -> tuple[bool, float, float]:
    """The DLS inverse V diag(s / (s^2 + l^2)) U^T (n, k) of J (k, n) from its SVD, with sigma_min and l.

    The SVD is a one-sided Jacobi on the rows of J (of J^T when k > n), so the inverse is formed as
    B^T diag(1 / (s^2 + l^2)) G with B = G J (rows s_i v_i^T): no squared condition number. With l = 0,
    singular values below rcond * s_max count as zero (the pseudo-inverse).

    Args:
        jacobian: J (k, n).
        damping: a fixed l >= 0 (used when ``epsilon`` is 0).
        epsilon, lambda_max: the variable damping of amundsen2018 eq. 6 when epsilon > 0.
        rcond: with l = 0, the relative cut-off of singular values (``uvms.numerics.inverses.RCOND``).
        floor: singular values at or below it count as zero, damped or not (0: none).
        out: (n, k) written with the inverse.

    Returns:
        (converged (False for a non-finite J), sigma_min (0 when k > n), l used).
    """
    converged, wide, work, rotation, factors, sigma_min, used = decompose(jacobian, damping, epsilon, lambda_max,
                                                                          rcond, floor)
    if not converged:
        return False, sigma_min, used
    left, right = (rotation, work) if wide else (work, rotation)  # A^+ = right^T diag(factors) left
    out[:, :] = 0.0
    for row in range(left.shape[0]):
        if factors[row] == 0.0:
            continue
        for i in range(right.shape[1]):  # out += right_i^T f left_i
            weighted = right[row, i] * factors[row]
            for j in range(left.shape[1]):
                out[i, j] += weighted * left[row, j]
    return True, sigma_min, used
