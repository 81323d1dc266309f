"""Generalized inverses: pseudo-inverse, weighted pseudo-inverse, damped least squares.

All return the inverse matrix (n, m) of a Jacobian J (m, n), like ``numpy.linalg.pinv``.
"""

from __future__ import annotations

import numpy as np
from ..errors import SolverInputError

#: Relative cut-off below which singular values count as zero.
RCOND = 1e-12


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
        SolverInputError: W not (n,) positive or (n, n) symmetric positive definite.
    """
    jacobian = check_matrix(jacobian, "J")
    factor = weights_factor(weights, jacobian.shape[1])
    return factor.unscale(np.linalg.pinv(factor.scale(jacobian), rcond=rcond))


class WeightsFactor:
    """W = L L^T, applied as J -> J L^-T and X -> L^-T X (diagonal W: plain column scaling)."""

    def __init__(self, diagonal: np.ndarray | None = None, cholesky: np.ndarray | None = None) -> None:
        self.inverse_sqrt = None if diagonal is None else 1.0 / np.sqrt(diagonal)
        self.cholesky = cholesky

    def scale(self, jacobian: np.ndarray) -> np.ndarray:
        """J L^-T (k, n)."""
        if self.inverse_sqrt is not None:
            return jacobian * self.inverse_sqrt
        return np.linalg.solve(self.cholesky, jacobian.T).T

    def unscale(self, inverse: np.ndarray) -> np.ndarray:
        """L^-T X (n, k)."""
        if self.inverse_sqrt is not None:
            return inverse * self.inverse_sqrt[:, None]
        return np.linalg.solve(self.cholesky.T, inverse)


def weights_factor(weights: np.ndarray, size: int) -> WeightsFactor:
    """Factor a weighting matrix: (size,) positive diagonal or (size, size) symmetric positive definite."""
    weights = np.asarray(weights, dtype=float)
    if weights.ndim == 1:
        if weights.shape != (size,) or not np.all(np.isfinite(weights)):
            raise SolverInputError(f"W must be ({size},) or ({size}, {size}) and finite, got shape {weights.shape}")
        if np.any(weights <= 0):
            raise SolverInputError(f"W must be positive definite: diagonal entries must be > 0, got {weights}")
        return WeightsFactor(diagonal=weights)
    weights = check_matrix(weights, "W", (size, size))
    if np.max(np.abs(weights - weights.T)) > 1e-12 * np.abs(weights).max():
        raise SolverInputError("W must be symmetric")
    try:
        return WeightsFactor(cholesky=np.linalg.cholesky(weights))
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
        normal = jacobian @ jacobian.T
        normal[np.diag_indices(rows)] += damping**2
        return np.linalg.solve(normal, jacobian).T
    normal = jacobian.T @ jacobian
    normal[np.diag_indices(columns)] += damping**2
    return np.linalg.solve(normal, jacobian.T)


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
