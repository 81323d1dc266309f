"""The CLIK's solution, its joint-limit null-space motion, and a frame task's whole step (``uvms.solvers.clik``).

x = J_W^+ (c - J z0) + z0 of hoang2011 eq. 27 in one call, z0 = -alpha dS/dv of the joint-limit potential
(hoang2011 eq. 20-21, ``uvms.tasks.potential``), and the prepared step of one frame task: its rows, the
command, z0 and the solution after Pinocchio's joint kinematics, in one call.

The module imports numba, so it is loaded where a solver first uses it, not by ``import uvms``; its kernels
compile at their first call and are cached on disk (``cache=True``, see :mod:`uvms.numerics._kernels`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .dense import apply, dls_solve_into
from .pose import frame_rows_into
from .svd import decompose
from .weighted import weighted_columns

__all__ = ["CHOLESKY_CONDITIONING", "NOT_COMPUTED", "clik_solution_into", "frame_clik_into", "frame_constants",
           "joint_limit_motion_into", "weighted_sigma_min"]

#: A fixed damping l > 0 solves (J L^-T)(J L^-T)^T + l^2 I by Cholesky when each squared pivot exceeds this fraction
#: of its largest diagonal entry (a condition number of about 1e4 or less: the SVD's solution to about 1e-12,
#: relative); else, and for l = 0 or the variable damping, by the Jacobi SVD.
CHOLESKY_CONDITIONING = 1e-4
#: The sigma_min returned by a solution that did not compute it (Cholesky): it is computed when read.
NOT_COMPUTED = -1.0


@njit(cache=True)
def clik_solution_into(jacobian: np.ndarray, command: np.ndarray, inverse_sqrt: np.ndarray, transform: np.ndarray,
                       damping: float, epsilon: float, lambda_max: float, rcond: float, z0: np.ndarray,
                       out: np.ndarray) -> tuple[bool, float, float]:
    """The CLIK solution x = J_W^+ (c - J z0) + z0 (n,), J_W^+ the weighted, damped inverse, in one call.

    It is J_W^+ c + (I - J_W^+ J) z0 of hoang2011 eq. 27 (amundsen2018 eq. 7 with damping), with
    J_W^+ = L^-T (J L^-T)^+ for W = L L^T. A fixed damping l > 0 on a well-conditioned J L^-T solves its normal
    equations by Cholesky (:data:`CHOLESKY_CONDITIONING`; sigma_min is then not computed); otherwise the inverse
    of :func:`~.svd.svd_inverse_into` is applied to the one vector.

    Args:
        jacobian: J (k, n) of the solved columns.
        command: c = xdot_d + K e (k,).
        inverse_sqrt: W^-1/2 (n,) of a diagonal W, or empty.
        transform: L^-T (n, n) of a full W, or empty (used when ``inverse_sqrt`` is empty; both empty: W = I).
        damping, epsilon, lambda_max, rcond: as :func:`~.svd.svd_inverse_into`.
        z0: the null-space motion (n,), or empty for none.
        out: (n,) written with x.

    Returns:
        (converged (False for a non-finite J), sigma_min of J L^-T (0 when k > n; :data:`NOT_COMPUTED` after a
        Cholesky solve), l used).
    """
    rows, columns = jacobian.shape
    rhs = command.copy()  # c - J z0
    if z0.size:
        for row in range(rows):
            for col in range(columns):
                rhs[row] -= jacobian[row, col] * z0[col]
    scaled = weighted_columns(jacobian, inverse_sqrt, transform)  # J L^-T
    solution = np.zeros(columns)  # (J L^-T)^+ rhs
    sigma_min, used = NOT_COMPUTED, damping
    if not (epsilon == 0.0 and damping > 0.0 and rows <= columns
            and dls_solve_into(scaled, rhs, damping * damping, solution, CHOLESKY_CONDITIONING)):
        converged, wide, work, rotation, factors, sigma_min, used = decompose(scaled, damping, epsilon, lambda_max,
                                                                              rcond, 0.0)
        if not converged:
            return False, sigma_min, used
        left, right = (rotation, work) if wide else (work, rotation)  # A^+ = right^T diag(factors) left
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
def weighted_sigma_min(values: np.ndarray, rows: int, columns: int, inverse_sqrt: np.ndarray,
                       transform: np.ndarray) -> float:
    """sigma_min of J L^-T (0 when k > n) of J (k, n) held row by row in the first k n ``values``: the number
    :func:`clik_solution_into`'s SVD reports (the same :func:`~.svd.decompose`, compiled once for both), computed
    alone; NaN for a non-finite J."""
    jacobian = values[:rows * columns].reshape((rows, columns))
    converged, _, _, _, _, sigma_min, _ = decompose(weighted_columns(jacobian, inverse_sqrt, transform), 0.0, 0.0,
                                                    0.0, 0.0, 0.0)
    return sigma_min if converged else np.nan


@njit(cache=True)
def joint_limit_motion_into(q: np.ndarray, q_index: np.ndarray, v_index: np.ndarray, weights: np.ndarray,
                            middle: np.ndarray, range_squared: np.ndarray, alpha: float, z0: np.ndarray) -> None:
    """z0 = -alpha dS/dv of the joint-limit potential (hoang2011 eq. 20-21), written to ``z0`` (n,).

    z0[v_index] = -alpha c (q[q_index] - qbar) / range^2 (the operations of
    ``MidRangePotential.arm_gradient``), zero elsewhere; the arrays are a ``NullspaceTerms``'.
    """
    z0[:] = 0.0
    for entry in range(q_index.size):
        z0[v_index[entry]] = -alpha * (weights[entry] * (q[q_index[entry]] - middle[entry]) / range_squared[entry])


@njit(cache=True)
def frame_constants(indices: np.ndarray, constants: np.ndarray):
    """The prepared arrays of a frame task's CLIK, as views of the two arrays :func:`frame_clik_into` takes.

    ``indices`` (int64): [k, m, p, kind | rows (k) | columns (m) | q_index (p) | v_index (p)];
    ``constants`` (float64): [placement (16) | gain K (k k) | damping, epsilon, lambda_max, rcond, alpha |
    weights | weights c (p) | middle (p) | range^2 (p)], the weights W^-1/2 (n) for ``kind`` 1, L^-T (n n) for 2,
    none for 0 (W = I); n = the columns of v.

    Returns:
        (rows, columns, q_index, v_index, placement (4, 4), gain (k, k), settings (5,), inverse_sqrt,
        transform, c, middle, range^2).
    """
    count, moving, bounded, kind = indices[0], indices[1], indices[2], indices[3]
    rows = indices[4:4 + count]
    columns = indices[4 + count:4 + count + moving]
    q_index = indices[4 + count + moving:4 + count + moving + bounded]
    v_index = indices[4 + count + moving + bounded:4 + count + moving + 2 * bounded]
    placement = constants[:16].reshape((4, 4))
    gain = constants[16:16 + count * count].reshape((count, count))
    first = 16 + count * count
    settings = constants[first:first + 5]
    size = constants.size - first - 5 - 3 * bounded  # the weights' entries: 0, n or n n
    inverse_sqrt = constants[first + 5:first + 5 + size] if kind == 1 else np.empty(0)
    columns_count = int(np.sqrt(size)) if kind == 2 else 0
    transform = constants[first + 5:first + 5 + size].reshape((columns_count, columns_count)) if kind == 2 \
        else np.empty((0, 0))
    last = first + 5 + size
    weights = constants[last:last + bounded]
    middle = constants[last + bounded:last + 2 * bounded]
    range_squared = constants[last + 2 * bounded:last + 3 * bounded]
    return (rows, columns, q_index, v_index, placement, gain, settings, inverse_sqrt, transform, weights, middle,
            range_squared)


@njit(cache=True)
def frame_clik_into(joint_jacobians: np.ndarray, joint_translation: np.ndarray, joint_rotation: np.ndarray,
                    q: np.ndarray, target_translation: np.ndarray, target_rotation: np.ndarray,
                    target_rpy: np.ndarray, feedforward: np.ndarray, indices: np.ndarray, constants: np.ndarray,
                    v: np.ndarray, record: np.ndarray, dt: float,
                    displacement: np.ndarray) -> tuple[bool, float, float]:
    """The CLIK velocity of one frame task after Pinocchio's joint kinematics, in one call.

    The task's rows (:func:`~.pose.frame_rows_into`), the command c = xdot_d + K e, the null-space motion z0
    (:func:`joint_limit_motion_into`) and v = J_W^+ (c - J z0) + z0 (:func:`clik_solution_into`): the numbers of
    those steps called one by one. What does not change between calls comes in two arrays (a kernel's call costs
    about 60 ns per array argument).

    Args:
        joint_jacobians, joint_translation, joint_rotation: as :func:`~.pose.frame_rows_into`; q: (nq,).
        target_translation, target_rotation, target_rpy: p_d (3,) [m], R_d (3, 3) and rpy_d (3,) (empty: the log
            error), as :func:`~.pose.frame_rows_into`; feedforward: xdot_d (k,) on the rows.
        indices, constants: the prepared arrays (:func:`frame_constants`; alpha 0: no null-space motion).
        v: (nv,) written with the velocity.
        record: (k (nv + 2),) written with the task's Jacobian rows (k, nv), its error e (k,) and the command (k,).
        dt: a step [s] (0: none); displacement: (nv,) written with v dt when dt > 0 (what ``pin.integrate`` adds).

    Returns:
        (converged, sigma_min, l used), as :func:`clik_solution_into`.
    """
    (rows, columns, q_index, v_index, placement, gain, settings, inverse_sqrt, transform, weights, middle,
     range_squared) = frame_constants(indices, constants)
    count, size = rows.size, v.size
    jacobian = record[:count * size].reshape((count, size))
    error = record[count * size:count * (size + 1)]
    command = record[count * (size + 1):]
    frame_rows_into(joint_jacobians, joint_translation, joint_rotation, placement, columns, rows, target_translation,
                    target_rotation, target_rpy, jacobian, error)
    for row in range(count):
        total = 0.0
        for col in range(count):
            total += gain[row, col] * error[col]
        command[row] = feedforward[row] + total
    z0 = np.empty(0)
    if settings[4] > 0.0:
        z0 = np.empty(size)
        joint_limit_motion_into(q, q_index, v_index, weights, middle, range_squared, settings[4], z0)
    converged, sigma_min, used = clik_solution_into(jacobian, command, inverse_sqrt, transform, settings[0],
                                                    settings[1], settings[2], settings[3], z0, v)
    if converged and dt > 0.0:
        for col in range(size):
            displacement[col] = v[col] * dt
    return converged, sigma_min, used
