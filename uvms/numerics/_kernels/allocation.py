"""The thrust allocation's cheap step (:meth:`uvms.dynamics.thrusters.allocation.ThrustAllocator.allocate`) in one
compiled call.

When B^+ tau lies within the thrusters' bounds the allocation is a dozen numpy operations on vectors of 6-8 numbers,
each dominated by its dispatch; here they are one call, writing into the caller's arrays (a returned array costs
numba a boxing call per array). The products are BLAS's (numba's ``np.dot`` calls the
same OpenBLAS routine as numpy's ``@`` on the same arrays), every other entry is computed with the operations of the
numpy expressions it replaces, in their order (no fused multiply-add: numba contracts nothing without ``fastmath``),
and ``np.maximum`` / ``np.minimum`` pick their second argument between equal numbers (signed zeros), as numpy does: the
numbers are the same bit for bit.

The module imports numba, so it is loaded where an allocation first runs; its kernel compiles at its first call and is
cached on disk (``cache=True``, see :mod:`uvms.numerics._kernels`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["pseudo_inverse_thrusts"]


@njit(cache=True)
def pseudo_inverse_thrusts(inverse: np.ndarray, matrix: np.ndarray, wrench: np.ndarray, low: np.ndarray,
                           high: np.ndarray, lower: np.ndarray, upper: np.ndarray, slack: float, thrusts: np.ndarray,
                           achieved: np.ndarray, residual: np.ndarray) -> tuple[bool, bool, bool]:
    """(finite, within, exact) of the minimum-norm allocation f = B^+ tau, its arrays written.

    Args:
        inverse: B_r^+ (n, 6); matrix: B (6, n); wrench: tau (6,) [N, N m]; low, high: the bounds with the slack
            (n,) [N]; lower, upper: the bounds (n,) [N]; slack: the tolerance [N]; thrusts (n,), achieved (6,),
            residual (6,): written (what is computed).

    Returns:
        finite: every entry of tau is finite (else nothing is computed); within: B^+ tau lies within [low, high]
        (else only f is computed, into ``thrusts``); then f clipped to the bounds
        (``np.minimum(np.maximum(f, lower), upper)``) into ``thrusts``, B f into ``achieved``, tau - B f into
        ``residual`` and exact: |tau - B f|_inf <= 10 slack max(1, |tau|_inf) (the allocation's numpy expressions).
    """
    n = inverse.shape[0]
    for i in range(wrench.size):
        if not np.isfinite(wrench[i]):
            return False, False, False
    thrusts[:] = np.dot(inverse, wrench)
    for i in range(n):
        if not (thrusts[i] >= low[i] and thrusts[i] <= high[i]):
            return True, False, False
    for i in range(n):
        value = thrusts[i] if thrusts[i] > lower[i] else lower[i]  # np.maximum: the second between equals
        thrusts[i] = value if value < upper[i] else upper[i]  # np.minimum: likewise
    achieved[:] = np.dot(matrix, thrusts)
    largest_residual, largest_wrench = 0.0, 0.0
    for i in range(wrench.size):
        residual[i] = wrench[i] - achieved[i]
        largest_residual = max(largest_residual, abs(residual[i]))
        largest_wrench = max(largest_wrench, abs(wrench[i]))
    exact = largest_residual <= 10 * slack * max(1.0, largest_wrench)
    return True, True, exact
