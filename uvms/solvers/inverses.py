"""Generalized inverses: pseudo-inverse, weighted pseudo-inverse, damped least squares.

All return the inverse matrix (n, m) of a Jacobian J (m, n), like ``numpy.linalg.pinv``.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from ..errors import UVMSError

#: Relative cut-off below which singular values count as zero.
RCOND = 1e-12


class SolverInputError(UVMSError):
    """A Jacobian, weight, gain or damping of the wrong shape, non-finite or not positive definite."""


def check_matrix(matrix: np.ndarray, what: str, shape: tuple[int | None, int | None] = (None, None)) -> np.ndarray:
    """A finite 2-D float array of the given shape (None: any)."""
    array = np.asarray(matrix, dtype=float)
    if array.ndim != 2 or any(size is not None and size != actual for size, actual in zip(shape, array.shape)):
        expected = "x".join("n" if size is None else str(size) for size in shape)
        raise SolverInputError(f"{what} must be a {expected} matrix, got shape {array.shape}")
    if not np.all(np.isfinite(array)):
        raise SolverInputError(f"{what} has non-finite entries")
    return array


def pinv(jacobian: np.ndarray, rcond: float = RCOND) -> np.ndarray:
    """Moore-Penrose pseudo-inverse J^+ (n, m), rank-deficient J included."""
    return np.linalg.pinv(check_matrix(jacobian, "J"), rcond=rcond)


def weighted_pinv(jacobian: np.ndarray, weights: np.ndarray, rcond: float = RCOND) -> np.ndarray:
    """Weighted pseudo-inverse J_W^+ = W^-1 J^T (J W^-1 J^T)^-1 (hoang2011 eq. 15).

    q_dot = J_W^+ x_dot minimizes 1/2 q_dot^T W q_dot subject to J q_dot = x_dot.
    Computed as L^-T (J L^-T)^+ with W = L L^T, which stays exact when J loses rank.

    Raises:
        SolverInputError: W not (n, n), not symmetric or not positive definite.
    """
    jacobian = check_matrix(jacobian, "J")
    cholesky = weights_cholesky(weights, jacobian.shape[1])
    scaled = scipy.linalg.solve_triangular(cholesky, jacobian.T, lower=True).T  # J L^-T
    return scipy.linalg.solve_triangular(cholesky.T, np.linalg.pinv(scaled, rcond=rcond), lower=False)


def weights_cholesky(weights: np.ndarray, size: int) -> np.ndarray:
    """Lower Cholesky factor L of a symmetric positive-definite weighting matrix W = L L^T."""
    weights = np.asarray(weights, dtype=float)
    if weights.ndim == 1:
        weights = np.diag(weights)
    weights = check_matrix(weights, "W", (size, size))
    if not np.allclose(weights, weights.T, rtol=1e-12, atol=1e-12 * np.abs(weights).max()):
        raise SolverInputError("W must be symmetric")
    try:
        return np.linalg.cholesky(weights)
    except np.linalg.LinAlgError:
        raise SolverInputError(f"W must be positive definite (eigenvalues {np.linalg.eigvalsh(weights).round(6)})") from None


def dls(jacobian: np.ndarray, damping: float) -> np.ndarray:
    """Damped least-squares inverse J^T (J J^T + l^2 I)^-1 = (J^T J + l^2 I)^-1 J^T.

    q_dot = dls(J, l) x_dot minimizes |x_dot - J q_dot|^2 + l^2 |q_dot|^2, hence
    |q_dot| <= |x_dot| / (2 l). The smaller of the two normal matrices is factored.
    """
    jacobian = check_matrix(jacobian, "J")
    damping = check_damping(damping)
    rows, columns = jacobian.shape
    if damping == 0.0:
        return np.linalg.pinv(jacobian, rcond=RCOND)
    if rows <= columns:
        normal = jacobian @ jacobian.T + damping**2 * np.eye(rows)
        return scipy.linalg.solve(normal, jacobian, assume_a="pos").T
    normal = jacobian.T @ jacobian + damping**2 * np.eye(columns)
    return scipy.linalg.solve(normal, jacobian.T, assume_a="pos")


def check_damping(damping: float) -> float:
    """A finite damping >= 0."""
    try:
        value = float(damping)
    except (TypeError, ValueError):
        raise SolverInputError(f"damping must be a number, got {damping!r}") from None
    if not np.isfinite(value) or value < 0.0:
        raise SolverInputError(f"damping must be finite and >= 0, got {damping!r}")
    return value


def variable_damping(sigma_min: float, epsilon: float, lambda_max: float) -> float:
    """Damping factor l of amundsen2018 eq. 6 (Chiaverini et al.).

    l^2 = 0 when sigma_min >= epsilon, else (1 - (sigma_min / epsilon)^2) lambda_max^2.
    """
    if not (np.isfinite(epsilon) and epsilon > 0 and np.isfinite(lambda_max) and lambda_max >= 0):
        raise SolverInputError(f"variable damping needs epsilon > 0 and lambda_max >= 0, got {epsilon!r}, {lambda_max!r}")
    if sigma_min >= epsilon:
        return 0.0
    return float(np.sqrt(1.0 - (sigma_min / epsilon) ** 2) * lambda_max)


def smallest_singular_value(jacobian: np.ndarray) -> float:
    """sigma_min of J over min(m, n) singular values (0 for an empty matrix)."""
    if jacobian.size == 0:
        return 0.0
    return float(np.linalg.svd(jacobian, compute_uv=False)[-1])
