"""The CLIK's solution and its joint-limit null-space motion (``uvms.solvers.clik``).

x = J_W^+ (c - J z0) + z0 of hoang2011 eq. 27 in one call, and z0 = -alpha dS/dv of the joint-limit
potential (hoang2011 eq. 20-21, ``uvms.tasks.joint_limits``).

The module imports numba, so it is loaded where a solver first uses it, not by ``import uvms``; its kernels
compile at their first call and are cached on disk (``cache=True``, see :mod:`uvms.numerics._kernels`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .dense import apply
from .svd import decompose
from .weighted import weighted_columns

__all__ = ["clik_solution_into", "joint_limit_motion_into"]


@njit(cache=True)
def clik_solution_into(jacobian: np.ndarray, command: np.ndarray, inverse_sqrt: np.ndarray, transform: np.ndarray,
                       damping: float, epsilon: float, lambda_max: float, rcond: float, z0: np.ndarray,
                       out: np.ndarray) -> tuple[bool, float, float]:
    """The CLIK solution x = J_W^+ (c - J z0) + z0 (n,), J_W^+ the weighted, damped inverse, in one call.

    It is J_W^+ c + (I - J_W^+ J) z0 of hoang2011 eq. 27 (amundsen2018 eq. 7 with damping), with
    J_W^+ = L^-T (J L^-T)^+ for W = L L^T, the inverse of :func:`~.svd.svd_inverse_into` applied to one vector.

    Args:
        jacobian: J (k, n) of the solved columns.
        command: c = xdot_d + K e (k,).
        inverse_sqrt: W^-1/2 (n,) of a diagonal W, or empty.
        transform: L^-T (n, n) of a full W, or empty (used when ``inverse_sqrt`` is empty; both empty: W = I).
        damping, epsilon, lambda_max, rcond: as :func:`~.svd.svd_inverse_into`.
        z0: the null-space motion (n,), or empty for none.
        out: (n,) written with x.

    Returns:
        (converged (False for a non-finite J), sigma_min of J L^-T (0 when k > n), l used).
    """
    rows, columns = jacobian.shape
    rhs = command.copy()  # c - J z0
    if z0.size:
        for row in range(rows):
            for col in range(columns):
                rhs[row] -= jacobian[row, col] * z0[col]
    scaled = weighted_columns(jacobian, inverse_sqrt, transform)  # J L^-T
    converged, wide, work, rotation, factors, sigma_min, used = decompose(scaled, damping, epsilon, lambda_max,
                                                                          rcond, 0.0)
    if not converged:
        return False, sigma_min, used
    left, right = (rotation, work) if wide else (work, rotation)  # A^+ = right^T diag(factors) left
    solution = np.zeros(columns)  # (J L^-T)^+ rhs
    for row in range(left.shape[0]):
        if factors[row] == 0.0:
            continue
        projected = 0.0
        for col in range(left.shape[1]):
            projected += left[row, col] * rhs[col]
        projected *= factors[row]
        for col in range(right.shape[1]):
            solution[col] += right[row, col] * projected
    if inverse_sqrt.size:
        for col in range(columns):
            solution[col] *= inverse_sqrt[col]
    elif transform.size:
        solution = apply(transform, solution)
    for col in range(columns):
        out[col] = solution[col] + z0[col] if z0.size else solution[col]
    return True, sigma_min, used


@njit(cache=True)
def joint_limit_motion_into(q: np.ndarray, q_index: np.ndarray, v_index: np.ndarray, weights: np.ndarray,
                            middle: np.ndarray, range_squared: np.ndarray, alpha: float, z0: np.ndarray) -> None:
    """z0 = -alpha dS/dv of the joint-limit potential (hoang2011 eq. 20-21), written to ``z0`` (n,).

    z0[v_index] = -alpha c (q[q_index] - qbar) / range^2 (the operations of
    ``JointLimitPotential.arm_gradient``), zero elsewhere; the arrays are a ``NullspaceTerms``'.
    """
    z0[:] = 0.0
    for entry in range(q_index.size):
        z0[v_index[entry]] = -alpha * (weights[entry] * (q[q_index[entry]] - middle[entry]) / range_squared[entry])
