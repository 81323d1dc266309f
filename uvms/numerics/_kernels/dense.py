"""Dense products in loops and the Cholesky/DLS solve of the normal equations.

Products, scalings and copies are written as loops: numba's BLAS binding and its broadcasting slice
assignment cost seconds of compilation each, and at (6, nv) sizes the loops are as fast. The Cholesky
solve and the DLS solution J^T (J J^T + d I)^-1 b are the Newton steps of the IK (``uvms.solvers.ik``).

The module imports numba, so it is loaded where a solver first uses it, not by ``import uvms``; its kernels
compile at their first call and are cached on disk (``cache=True``, see :mod:`uvms.numerics._kernels`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["apply", "cholesky_solve_in_place", "copy_into", "dls_solve_into", "product", "scale_matrix",
           "subtract_in_place"]


@njit(cache=True, inline="always")
def product(left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """left @ right (m, n) of (m, k) and (k, n) in loops (numba's BLAS binding takes a second to compile)."""
    rows, inner = left.shape
    out = np.zeros((rows, right.shape[1]))
    for row in range(rows):
        for k in range(inner):
            value = left[row, k]
            for col in range(right.shape[1]):
                out[row, col] += value * right[k, col]
    return out


@njit(cache=True, inline="always")
def apply(matrix: np.ndarray, vector: np.ndarray) -> np.ndarray:
    """matrix @ vector (m,) of (m, k) and (k,) in loops."""
    out = np.zeros(matrix.shape[0])
    for row in range(matrix.shape[0]):
        total = 0.0
        for k in range(matrix.shape[1]):
            total += matrix[row, k] * vector[k]
        out[row] = total
    return out


@njit(cache=True, inline="always")
def scale_matrix(matrix: np.ndarray, scale: np.ndarray, rows: bool) -> np.ndarray:
    """diag(scale) matrix (``rows``: row i times scale[i]) or matrix diag(scale) (column j times scale[j]),
    (m, n), a new array."""
    out = np.empty(matrix.shape)
    for row in range(matrix.shape[0]):
        for col in range(matrix.shape[1]):
            out[row, col] = matrix[row, col] * scale[row if rows else col]
    return out


@njit(cache=True, inline="always")
def copy_into(target: np.ndarray, source: np.ndarray) -> None:
    """target[:, :] = source (m, n) in loops (numba's broadcasting slice assignment takes seconds to compile)."""
    for row in range(source.shape[0]):
        for col in range(source.shape[1]):
            target[row, col] = source[row, col]


@njit(cache=True, inline="always")
def subtract_in_place(matrix: np.ndarray, other: np.ndarray) -> None:
    """matrix -= other, both (m, n)."""
    for row in range(matrix.shape[0]):
        for col in range(matrix.shape[1]):
            matrix[row, col] -= other[row, col]


@njit(cache=True)
def cholesky_solve_in_place(system: np.ndarray, rhs: np.ndarray, floor: float = 0.0) -> bool:
    """Solve A y = b for a symmetric positive definite A (k, k) by A = L L^T, overwriting both.

    The lower triangle of ``system`` becomes L and ``rhs`` becomes y; the upper triangle is not read.

    Args:
        system: A (k, k); rhs: b (k,).
        floor: a squared pivot L_ii^2 must exceed it (0: A positive definite; larger: A well-conditioned).

    Returns:
        False when a squared pivot is <= ``floor`` (A not numerically positive definite, or too ill-conditioned;
        ``rhs`` is then partly overwritten and not a solution), True otherwise.
    """
    size = system.shape[0]
    for col in range(size):
        pivot = system[col, col]
        for inner in range(col):
            pivot -= system[col, inner] * system[col, inner]
        if not pivot > floor:  # also catches NaN
            return False
        pivot = np.sqrt(pivot)
        system[col, col] = pivot
        for row in range(col + 1, size):
            value = system[row, col]
            for inner in range(col):
                value -= system[row, inner] * system[col, inner]
            system[row, col] = value / pivot
    for row in range(size):  # L z = b
        value = rhs[row]
        for inner in range(row):
            value -= system[row, inner] * rhs[inner]
        rhs[row] = value / system[row, row]
    for row in range(size - 1, -1, -1):  # L^T y = z
        value = rhs[row]
        for inner in range(row + 1, size):
            value -= system[inner, row] * rhs[inner]
        rhs[row] = value / system[row, row]
    return True


@njit(cache=True)
def dls_solve_into(jacobian: np.ndarray, rhs: np.ndarray, damping_squared: float, out: np.ndarray,
                   conditioning: float = 0.0) -> bool:
    """out = J^T (J J^T + d I)^-1 b (n,): the DLS solution for one right-hand side, in normal-equation form.

    Args:
        jacobian: J (k, n); rhs: b (k,) (not modified); damping_squared: d = l^2 >= 0.
        out: (n,) written with the solution.
        conditioning: refuse the system when a squared Cholesky pivot is <= this times its largest diagonal
            entry (0: only when it is not positive definite). The solution's relative error grows as the
            condition number of J J^T + d I, about the inverse of that ratio, times the rounding unit.

    Returns:
        False when J J^T + d I is not numerically positive definite or is refused (``out`` is then not written).
    """
    rows, columns = jacobian.shape
    system = np.empty((rows, rows))  # J J^T + d I (lower triangle)
    solution = np.empty(rows)
    largest = 0.0
    for row in range(rows):
        solution[row] = rhs[row]
        for other in range(row + 1):
            dot = 0.0
            for col in range(columns):
                dot += jacobian[row, col] * jacobian[other, col]
            system[row, other] = dot
        system[row, row] += damping_squared
        largest = max(largest, system[row, row])
    if not cholesky_solve_in_place(system, solution, conditioning * largest if conditioning > 0.0 else 0.0):
        return False
    for col in range(columns):  # J^T y
        value = 0.0
        for row in range(rows):
            value += jacobian[row, col] * solution[row]
        out[col] = value
    return True


@njit(cache=True)
def clip_into(values: np.ndarray, lower: np.ndarray, upper: np.ndarray, out: np.ndarray) -> None:
    """``np.clip(values, lower, upper)`` (n,) into ``out`` (``values`` itself allowed): numpy's max-then-min per
    entry, its comparisons (a NaN kept; an entry equal to a bound, a signed zero among them, gives the bound), the
    same bits."""
    for i in range(values.shape[0]):
        value = values[i]
        low = value if np.isnan(value) or value > lower[i] else lower[i]
        out[i] = low if np.isnan(low) or low < upper[i] else upper[i]
