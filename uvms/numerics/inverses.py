"""Generalized inverses of a Jacobian J (k, n), the one module every solver inverts with.

- :func:`pinv`: Moore-Penrose pseudo-inverse J^+.
- :func:`weighted_pinv`: J_W^+ = W^-1 J^T (J W^-1 J^T)^-1 (hoang2011 eq. 15), via W = L L^T.
- :func:`dls`: damped least squares J^T (J J^T + l^2 I)^-1 with a fixed damping l.
- :class:`VariableDamping` / :func:`variable_damping`: the damping of amundsen2018 eq. 6.
- :func:`damped_weighted_inverse` (:func:`svd_inverse` underneath): weighted and
  damped (fixed or variable) from one SVD, with its diagnostics sigma_min and l.
- :func:`dls_solve`: the normal-equation form J^T (J J^T + d I)^-1 b for one
  right-hand side, one Cholesky factorization (a compiled kernel): cheaper when only
  J^+ b is needed (the Newton steps of :func:`~uvms.solvers.ik.solve_ik`).

The matrix forms return the inverse (n, k), like ``numpy.linalg.pinv``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..errors import NumericalError, SolverInputError
from .checks import check_damping, check_matrix, check_variable_damping, check_weights

__all__ = ["RCOND", "SolverInputError", "VariableDamping", "WeightsFactor", "check_damping", "check_matrix",
           "WeightedInverse", "damped_weighted_inverse", "dls", "dls_solve", "pinv", "prepared_svd_inverse",
           "smallest_singular_value", "svd_inverse", "variable_damping", "weighted_pinv", "weights_factor",
           "weights_subset"]

#: Relative cut-off below which singular values count as zero (that of the compiled inverse).
RCOND = 1e-12


# ------------------------------------------------------------------ weights
class WeightsFactor:
    """W = L L^T, applied as J -> J L^-T and X -> L^-T X (diagonal W: plain column scaling)."""

    def __init__(self, diagonal: np.ndarray | None = None, cholesky: np.ndarray | None = None) -> None:
        self.inverse_sqrt = None if diagonal is None else 1.0 / np.sqrt(diagonal)  # (n,)
        self.cholesky = cholesky  # (n, n) lower triangular L

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
    """Factor a weighting matrix W: (size,) positive diagonal or (size, size) symmetric positive definite.

    Raises:
        SolverInputError: wrong shape, non-finite, not symmetric or not positive definite.
    """
    weights = check_weights(weights, size)
    if weights.ndim == 1:
        return WeightsFactor(diagonal=weights)
    try:
        return WeightsFactor(cholesky=np.linalg.cholesky(weights))
    except np.linalg.LinAlgError:
        raise SolverInputError("W must be positive definite "
                               f"(eigenvalues {np.linalg.eigvalsh(weights).round(6)})") from None


def weights_subset(weights: np.ndarray, indices: np.ndarray, size: int) -> np.ndarray:
    """Rows and columns ``indices`` of W given as (size,) diagonal or (size, size): (m,) or (m, m)."""
    weights = check_weights(weights, size)
    return weights[indices] if weights.ndim == 1 else weights[np.ix_(indices, indices)]


# --------------------------------------------------------- undamped inverses
def pinv(jacobian: np.ndarray, rcond: float = RCOND) -> np.ndarray:
    """Moore-Penrose pseudo-inverse J^+ (n, k), rank-deficient J included."""
    return np.linalg.pinv(check_matrix(jacobian, "J"), rcond=rcond)


def weighted_pinv(jacobian: np.ndarray, weights: np.ndarray, rcond: float = RCOND) -> np.ndarray:
    """Weighted pseudo-inverse J_W^+ = W^-1 J^T (J W^-1 J^T)^-1 (n, k) (hoang2011 eq. 15).

    q_dot = J_W^+ x_dot minimizes 1/2 q_dot^T W q_dot subject to J q_dot = x_dot.
    Computed as L^-T (J L^-T)^+ with W = L L^T, which stays exact when J loses rank.

    Raises:
        SolverInputError: W not (n,) positive or (n, n) symmetric positive definite.
    """
    jacobian = check_matrix(jacobian, "J")
    factor = weights_factor(weights, jacobian.shape[1])
    return factor.unscale(np.linalg.pinv(factor.scale(jacobian), rcond=rcond))


def smallest_singular_value(jacobian: np.ndarray) -> float:
    """sigma_min of J over min(k, n) singular values (0 for an empty matrix)."""
    if jacobian.size == 0:
        return 0.0
    return float(np.linalg.svd(jacobian, compute_uv=False)[-1])


# ---------------------------------------------------------- damped inverses
def dls(jacobian: np.ndarray, damping: float) -> np.ndarray:
    """Damped least-squares inverse J^T (J J^T + l^2 I)^-1 = (J^T J + l^2 I)^-1 J^T (n, k).

    q_dot = dls(J, l) x_dot minimizes |x_dot - J q_dot|^2 + l^2 |q_dot|^2, hence
    |q_dot| <= |x_dot| / (2 l). The smaller of the two normal matrices is factored;
    l = 0 gives the pseudo-inverse.
    """
    jacobian = check_matrix(jacobian, "J")
    damping = check_damping(damping)
    rows, columns = jacobian.shape
    if damping == 0.0:
        return np.linalg.pinv(jacobian, rcond=RCOND)
    if rows <= columns:
        normal = jacobian @ jacobian.T  # (k, k)
        normal[np.diag_indices(rows)] += damping**2
        return np.linalg.solve(normal, jacobian).T
    normal = jacobian.T @ jacobian  # (n, n)
    normal[np.diag_indices(columns)] += damping**2
    return np.linalg.solve(normal, jacobian.T)


def dls_solve(jacobian: np.ndarray, rhs: np.ndarray, damping_squared: float) -> np.ndarray:
    """x = J^T (J J^T + d I)^-1 b (n,): the DLS solution for one right-hand side, in normal-equation form.

    One Cholesky factorization of the (k, k) row-space matrix in the compiled kernel
    :func:`~uvms.numerics._kernels.dense.dls_solve_into` (the one the Newton steps of
    :func:`~uvms.solvers.ik.solve_ik` call), no inverse formed and no validation: the caller has checked its inputs
    once.

    Args:
        jacobian: J (k, n), finite.
        rhs: b (k,).
        damping_squared: d = l^2 > 0 [-] (keeps the system positive definite).

    Raises:
        SolverInputError: the system is not numerically positive definite.
    """
    from ._kernels.dense import dls_solve_into  # numba: loaded at the first solve, not by ``import uvms``

    solution = np.empty(jacobian.shape[1])
    if not dls_solve_into(jacobian, rhs, float(damping_squared), solution):  # never return garbage
        raise SolverInputError(f"DLS system J J^T + {float(damping_squared):g} I not positive definite: "
                               "is the Jacobian finite, the damping > 0?")
    return solution


def variable_damping(sigma_min: float, epsilon: float, lambda_max: float) -> float:
    """Damping factor l of amundsen2018 eq. 6 (Chiaverini et al.).

    l^2 = 0 when sigma_min >= epsilon, else (1 - (sigma_min / epsilon)^2) lambda_max^2.
    """
    from ._kernels.svd import variable_damping_value  # the formula the compiled inverse applies

    check_variable_damping(epsilon, lambda_max)
    return float(variable_damping_value(float(sigma_min), float(epsilon), float(lambda_max)))


@dataclass(frozen=True)
class VariableDamping:
    """Damping of amundsen2018 eq. 6: l^2 = (1 - (s_min/epsilon)^2) lambda_max^2 when s_min < epsilon.

    Attributes:
        epsilon: size of the singular region in sigma_min [-], > 0.
        lambda_max: damping at the singularity [-], >= 0.
    """

    epsilon: float
    lambda_max: float

    def __post_init__(self) -> None:
        check_variable_damping(self.epsilon, self.lambda_max)

    def __call__(self, sigma_min: float) -> float:
        return variable_damping(sigma_min, self.epsilon, self.lambda_max)


def svd_inverse(jacobian: np.ndarray, damping: float | VariableDamping) -> tuple[np.ndarray, float, float]:
    """DLS inverse V diag(s / (s^2 + l^2)) U^T (n, k) from one SVD, which also gives sigma_min and the variable damping.

    With l = 0, singular values below RCOND * s_max count as zero (the pseudo-inverse).

    Returns:
        (inverse (n, k), sigma_min (0 when k > n), damping l used).
    """
    return prepared_svd_inverse(jacobian, damping if isinstance(damping, VariableDamping) else check_damping(damping))


def prepared_svd_inverse(jacobian: np.ndarray, damping: float | VariableDamping) -> tuple[np.ndarray, float, float]:
    """:func:`svd_inverse` of a damping already checked (a float >= 0 or a VariableDamping): the solvers' inner loop.

    One compiled call (:func:`~uvms.numerics._kernels.svd.svd_inverse_into`: a one-sided Jacobi SVD, the damping
    and the inverse), a third of LAPACK's dgesdd through scipy on these small matrices.

    Raises:
        NumericalError: the SVD did not converge (a non-finite Jacobian).
    """
    from ._kernels.svd import svd_inverse_into  # numba: loaded at the first solve, not by ``import uvms``

    inverse = np.empty((jacobian.shape[1], jacobian.shape[0]))
    converged, sigma_min, used = svd_inverse_into(np.ascontiguousarray(jacobian), *damping_parameters(damping), RCOND,
                                                  0.0, inverse)
    return inverse, *converged_or_refused(converged, jacobian.shape, sigma_min, used)


def damping_parameters(damping: float | VariableDamping) -> tuple[float, float, float]:
    """(fixed l, epsilon, lambda_max) of a checked damping, as the kernels take it (epsilon = 0: fixed)."""
    if isinstance(damping, VariableDamping):
        return 0.0, damping.epsilon, damping.lambda_max
    return damping, 0.0, 0.0


def converged_or_refused(converged: bool, shape: tuple[int, ...], sigma_min: float, used: float) -> tuple[float, float]:
    """(sigma_min, damping used) of a compiled inverse that converged.

    Raises:
        NumericalError: it did not (a non-finite Jacobian): never a NaN velocity.
    """
    if not converged:
        raise NumericalError(f"the SVD of the {shape[0]}x{shape[1]} task Jacobian did not converge: is it finite?")
    return sigma_min, used


def damped_weighted_inverse(
    jacobian: np.ndarray, weights: np.ndarray | None, damping: float | VariableDamping
) -> tuple[np.ndarray, float, float]:
    """Inverse of J (k, n) weighted by W and damped: L^-T dls(J L^-T, l), W = L L^T.

    With W = I and l = 0 this is the pseudo-inverse; with l = 0 the weighted
    pseudo-inverse of hoang2011 eq. 15; with W = I the DLS of amundsen2018 eq. 4-5.

    Args:
        jacobian: J (k, n).
        weights: W, (n,) diagonal or (n, n) SPD; None: identity.
        damping: fixed l >= 0 or a :class:`VariableDamping`.

    Returns:
        (inverse (n, k), sigma_min of the weighted Jacobian, damping used).
    """
    checked = damping if isinstance(damping, VariableDamping) else check_damping(damping)
    return WeightedInverse(weights, jacobian.shape[1])(jacobian, checked)


class WeightedInverse:
    """:func:`damped_weighted_inverse` for Jacobians of ``size`` columns with W checked and factored once (the
    solvers' inner loops).

    Args:
        weights: W, (size,) diagonal or (size, size) SPD; None or a diagonal of ones: I (no scaling, the
            same numbers as scaling by 1).
        size: the number of columns n.

    Raises:
        SolverInputError: W of a wrong shape, not finite or not positive definite.
    """

    def __init__(self, weights: np.ndarray | None, size: int) -> None:
        weights = None if weights is None else check_weights(weights, size)
        identity = weights is None or (weights.ndim == 1 and bool(np.all(weights == 1.0)))
        self.factor = None if identity else weights_factor(weights, size)
        #: W as the kernels take it: (W^-1/2 (n,) of a diagonal or empty, L^-T (n, n) of a full W or empty); I: both
        self.kernel_weights = (np.zeros(0), np.zeros((0, 0)))
        if self.factor is not None and self.factor.inverse_sqrt is not None:
            self.kernel_weights = (np.ascontiguousarray(self.factor.inverse_sqrt), np.zeros((0, 0)))
        elif self.factor is not None:
            self.kernel_weights = (np.zeros(0), np.linalg.solve(self.factor.cholesky.T, np.eye(size)))  # L^-T
        self._no_motion = np.zeros(0)

    def solve(self, jacobian: np.ndarray, command: np.ndarray, damping: float | VariableDamping,
              nullspace_motion: np.ndarray | None) -> tuple[np.ndarray, float | Callable[[], float], float]:
        """(x = J_W^+ (c - J z0) + z0 (n,), sigma_min of the weighted J, damping used) in one compiled call.

        The CLIK's solution (:func:`~uvms.numerics._kernels.clik.clik_solution_into`): the numbers of this
        inverse applied to c, plus the null-space motion z0 projected (None: none), to rounding. A fixed damping
        solved by Cholesky does not compute sigma_min: it is then a function that computes it
        (:meth:`sigma_min`), for a result to call when it is read.

        Raises:
            NumericalError: the SVD did not converge (a non-finite Jacobian).
        """
        from ._kernels.clik import clik_solution_into  # numba: loaded at the first solve, not by ``import uvms``

        solution = np.empty(jacobian.shape[1])
        z0 = self._no_motion if nullspace_motion is None else nullspace_motion
        # C order: one compiled form of the kernel serves every caller (numba compiles one per array layout)
        matrix = np.ascontiguousarray(jacobian)
        converged, sigma_min, used = clik_solution_into(matrix, command, *self.kernel_weights,
                                                        *damping_parameters(damping), RCOND, z0, solution)
        sigma_min, used = converged_or_refused(converged, jacobian.shape, sigma_min, used)
        return solution, (lambda: self.sigma_min(matrix)) if sigma_min < 0.0 else sigma_min, used

    def sigma_min(self, jacobian: np.ndarray) -> float:
        """sigma_min of the weighted J (k, n) (0 when k > n): the number the SVD of :meth:`solve` reports."""
        from ._kernels.clik import weighted_sigma_min  # numba: loaded at the first solve, not by ``import uvms``

        rows, columns = jacobian.shape
        return float(weighted_sigma_min(np.ascontiguousarray(jacobian).ravel(), rows, columns, *self.kernel_weights))

    def __call__(self, jacobian: np.ndarray, damping: float | VariableDamping) -> tuple[np.ndarray, float, float]:
        """(inverse (n, k), sigma_min of the weighted J, damping used) of J (k, n), ``damping`` already checked
        (:func:`~uvms.numerics._kernels.weighted.weighted_inverse_into`).

        Raises:
            NumericalError: the SVD did not converge (a non-finite Jacobian).
        """
        from ._kernels.weighted import weighted_inverse_into  # numba: loaded at the first solve, not by ``import uvms``

        inverse = np.empty((jacobian.shape[1], jacobian.shape[0]))
        converged, sigma_min, used = weighted_inverse_into(np.ascontiguousarray(jacobian), *self.kernel_weights,
                                                           *damping_parameters(damping), RCOND, 0.0, inverse)
        return inverse, *converged_or_refused(converged, jacobian.shape, sigma_min, used)
