"""The weighted, damped inverse L^-T (X L^-T)^+ of a weighting W = L L^T (diagonal, full or identity).

The module imports numba, so it is loaded where a solver first uses it, not by ``import uvms``; its kernels
compile at their first call and are cached on disk (``cache=True``, see :mod:`uvms.numerics._kernels`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .dense import copy_into, product, scale_matrix
from .svd import svd_inverse_into

__all__ = ["weighted_columns", "weighted_inverse_into", "weighted_norm"]


@njit(cache=True)
def weighted_columns(matrix: np.ndarray, inverse_sqrt: np.ndarray, transform: np.ndarray) -> np.ndarray:
    """X L^-T (m, n) of X (m, n), W = L L^T: X W^-1/2 for a diagonal W (``inverse_sqrt`` (n,)), X L^-T for a
    full one (``transform`` (n, n)), X itself when both are empty (W = I; not a copy)."""
    if inverse_sqrt.size:
        return scale_matrix(matrix, inverse_sqrt, False)
    if transform.size:
        return product(matrix, transform)
    return matrix


@njit(cache=True)
def weighted_norm(matrix: np.ndarray, inverse_sqrt: np.ndarray, transform: np.ndarray) -> float:
    """The Frobenius norm of X L^-T (W = L L^T; W as :func:`weighted_inverse_into` takes it) of X (m, n)."""
    weighted = weighted_columns(matrix, inverse_sqrt, transform)
    total = 0.0
    for row in range(weighted.shape[0]):
        for col in range(weighted.shape[1]):
            total += weighted[row, col] * weighted[row, col]
    return np.sqrt(total)


@njit(cache=True)
def weighted_inverse_into(matrix: np.ndarray, inverse_sqrt: np.ndarray, transform: np.ndarray, damping: float,
                          epsilon: float, lambda_max: float, rcond: float, floor: float,
                          out: np.ndarray) -> tuple[bool, float, float]:
    """The weighted, damped inverse L^-T (X L^-T)^+ (n, m) of X (m, n), W = L L^T, written to ``out``.

    Args:
        matrix: X (m, n).
        inverse_sqrt: W^-1/2 (n,) of a diagonal W, or empty; transform: L^-T (n, n) of a full W, or empty
            (both empty: W = I).
        damping, epsilon, lambda_max, rcond, floor: as :func:`~.svd.svd_inverse_into` (floor: of X L^-T).
        out: (n, m).

    Returns:
        (converged, sigma_min of X L^-T, l used), as :func:`~.svd.svd_inverse_into`.
    """
    weighted = weighted_columns(matrix, inverse_sqrt, transform)  # X L^-T
    if transform.size and not inverse_sqrt.size:
        scaled = np.empty_like(out)  # (X L^-T)^+, then L^-T times it
        converged, sigma_min, used = svd_inverse_into(weighted, damping, epsilon, lambda_max, rcond, floor, scaled)
        copy_into(out, product(transform, scaled))
        return converged, sigma_min, used
    converged, sigma_min, used = svd_inverse_into(weighted, damping, epsilon, lambda_max, rcond, floor, out)
    if inverse_sqrt.size:  # W^-1/2 (X W^-1/2)^+: its rows scale
        for row in range(out.shape[0]):
            for col in range(out.shape[1]):
                out[row, col] *= inverse_sqrt[row]
    return converged, sigma_min, used
