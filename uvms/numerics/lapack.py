"""numpy's LAPACK solve without ``numpy.linalg.solve``'s wrapper, for the small systems of inner loops that run in
Python (a compiled kernel calls the same ``dgesv`` itself: :mod:`uvms.numerics._kernels.solve`)."""

from __future__ import annotations

import math

import numpy as np

from ..errors import NumericalError


def numpy_solve(matrix: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """x (n,) with A x = b, or X (n, k) with A X = B: the numbers of ``numpy.linalg.solve`` (its LAPACK gufunc,
    called directly), without its wrapper's checks and error-state context (about 2 us of its 8 on a 6 x 6 system).

    Raises:
        NumericalError: a singular A (a non-finite solution).
    """
    if rhs.ndim == 1:
        solution = _solve_vector(matrix, rhs, signature="dd->d")  # a singular A: NaN (numpy's RuntimeWarning)
        finite = math.isfinite(solution.dot(solution))  # one product: np.isfinite(...).all() would double the cost
    else:
        solution = _solve_matrix(matrix, rhs, signature="dd->d")
        finite = bool(np.isfinite(solution).all())
    if not finite:
        raise singular_system(matrix.shape[0])
    return solution


def singular_system(size: int, info: int | None = None) -> NumericalError:
    """The error of a (size, size) system a solve could not solve, from Python or from a compiled kernel
    (:mod:`uvms.numerics._kernels.solve`): numpy's (singular, or a solution not finite), or with LAPACK's ``info`` > 0
    a dgesv whose U_ii is exactly zero."""
    if info is not None:
        return NumericalError(f"singular {size}x{size} system (LAPACK dgesv info {info})")
    return NumericalError(f"singular or overflowing {size}x{size} system")


try:  # numpy's gufuncs behind linalg.solve (numpy 1.x and 2.x): one for a vector b, one for a matrix B
    from numpy.linalg._umath_linalg import solve as _solve_matrix
    from numpy.linalg._umath_linalg import solve1 as _solve_vector
except ImportError:  # pragma: no cover - another numpy: its public function, the same numbers
    def _solve_vector(matrix: np.ndarray, rhs: np.ndarray, signature: str) -> np.ndarray:  # noqa: ARG001
        with np.errstate(all="ignore"):
            try:
                return np.linalg.solve(matrix, rhs)
            except np.linalg.LinAlgError:
                return np.full(rhs.shape, np.nan)

    _solve_matrix = _solve_vector
