"""Compiled dense kernels of the solvers' inner loops (numba, nopython mode).

A hot loop's step is a handful of products of (6, nv) matrices, a (k, k) Cholesky solve and a few
vector updates. Each numpy call costs 0.3-1 us of interpreter and dispatch overhead on arrays this
small, about what the arithmetic itself costs, so a step written as numpy calls is bounded by their
number. Here the whole dense part of a step is one compiled call; Pinocchio still computes every pose,
Jacobian, logarithm and integration.

The module imports numba, so it is loaded where a solver that uses it is built (``PoseCLIK``), not by
``import uvms``. The kernels compile at their first call and are cached on disk beside this file (or in
numba's user cache when the package folder is read-only): a first call in a fresh install takes a
few seconds, later processes load the machine code in a fraction of a second.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["cholesky_solve_in_place", "dls_pose_velocity", "dls_solve_into", "pose_error_norm", "project_into_box", "rotation_to_target"]


@njit(cache=True)
def cholesky_solve_in_place(system: np.ndarray, rhs: np.ndarray) -> bool:
    """Solve A y = b for a symmetric positive definite A (k, k) by A = L L^T, overwriting both.

    The lower triangle of ``system`` becomes L and ``rhs`` becomes y; the upper triangle is not read.

    Returns:
        False when A is not numerically positive definite (a pivot <= 0; ``rhs`` is then partly
        overwritten and not a solution), True otherwise.
    """
    size = system.shape[0]
    for col in range(size):
        pivot = system[col, col]
        for inner in range(col):
            pivot -= system[col, inner] * system[col, inner]
        if not pivot > 0.0:  # also catches NaN
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
def dls_solve_into(jacobian: np.ndarray, rhs: np.ndarray, damping_squared: float, out: np.ndarray) -> bool:
    """out = J^T (J J^T + d I)^-1 b (n,): the DLS solution for one right-hand side, in normal-equation form.

    Args:
        jacobian: J (k, n); rhs: b (k,) (not modified); damping_squared: d = l^2 >= 0.
        out: (n,) written with the solution.

    Returns:
        False when J J^T + d I is not numerically positive definite (``out`` is then not written).
    """
    rows, columns = jacobian.shape
    system = np.empty((rows, rows))  # J J^T + d I (lower triangle)
    solution = np.empty(rows)
    for row in range(rows):
        solution[row] = rhs[row]
        for other in range(row + 1):
            product = 0.0
            for col in range(columns):
                product += jacobian[row, col] * jacobian[other, col]
            system[row, other] = product
        system[row, row] += damping_squared
    if not cholesky_solve_in_place(system, solution):
        return False
    for col in range(columns):  # J^T y
        value = 0.0
        for row in range(rows):
            value += jacobian[row, col] * solution[row]
        out[col] = value
    return True


@njit(cache=True)
def rotation_to_target(transform_frame_to_world: np.ndarray, target_rotation: np.ndarray, out: np.ndarray) -> None:
    """out = R_d R^T (3, 3), the rotation whose log3 is the orientation error in world axes.

    Args:
        transform_frame_to_world: the frame's homogeneous pose (4, 4) (its rotation R is read).
        target_rotation: R_d (3, 3).
        out: (3, 3) written.
    """
    for row in range(3):
        for col in range(3):
            out[row, col] = (target_rotation[row, 0] * transform_frame_to_world[col, 0]
                             + target_rotation[row, 1] * transform_frame_to_world[col, 1]
                             + target_rotation[row, 2] * transform_frame_to_world[col, 2])


@njit(cache=True)
def pose_error_norm(transform_frame_to_world: np.ndarray, target_translation: np.ndarray,
                    rotation_error: np.ndarray, error: np.ndarray) -> float:
    """|e| [m, rad] of the pose error e = [p_d - p; log3(R_d R^T)], written to ``error`` (6,).

    Args:
        transform_frame_to_world: the frame's homogeneous pose (4, 4) (its translation is read).
        target_translation: p_d (3,) [m].
        rotation_error: log3(R_d R^T) (3,) [rad], from Pinocchio.
        error: (6,) written with e.
    """
    squared = 0.0
    for axis in range(3):
        error[axis] = target_translation[axis] - transform_frame_to_world[axis, 3]
        error[3 + axis] = rotation_error[axis]
        squared += error[axis] * error[axis] + rotation_error[axis] * rotation_error[axis]
    return np.sqrt(squared)


@njit(cache=True)
def project_into_box(q: np.ndarray, index: np.ndarray, lower: np.ndarray, upper: np.ndarray,
                     turns: np.ndarray) -> None:
    """Bring the bounded coordinates q[index] into [lower, upper] in place.

    A revolute coordinate (``turns``) outside its limits first moves by the multiple of 2 pi that puts it
    at or above ``lower``, when that lands inside (the same pose); what is still outside is clipped.
    """
    for entry in range(index.size):
        value = q[index[entry]]
        low, high = lower[entry], upper[entry]
        if value < low or value > high:
            if turns[entry]:
                wrapped = low + np.mod(value - low, 2.0 * np.pi)
                if wrapped <= high:
                    value = wrapped
            q[index[entry]] = min(max(value, low), high)


@njit(cache=True)
def dls_pose_velocity(
    jacobian: np.ndarray,
    transform_frame_to_world: np.ndarray,
    target_translation: np.ndarray,
    rotation_error: np.ndarray,
    gain: float,
    feedforward: np.ndarray,
    damping_squared: float,
    q: np.ndarray,
    q_index: np.ndarray,
    v_index: np.ndarray,
    nullspace_scale: np.ndarray,
    middle: np.ndarray,
    scale: float,
    error: np.ndarray,
    out: np.ndarray,
) -> bool:
    """scale * v (nv,) of the DLS CLIK of one 6-D pose task with a joint-limit null-space motion.

        e = [p_d - p; log3(R_d R^T)],  c = K e + xdot_d,  z0[v_index] = s (q[q_index] - middle)
        v = z0 + J^T (J J^T + d I)^-1 (c - J z0)

    which is J^+ c + (I - J^+ J) z0 with the DLS inverse J^+ = J^T (J J^T + d I)^-1.

    Args:
        jacobian: J (6, nv), world-aligned.
        transform_frame_to_world: the frame's homogeneous pose (4, 4) (its translation is read).
        target_translation: p_d (3,) [m].
        rotation_error: log3(R_d R^T) (3,) [rad], from Pinocchio.
        gain: K [1/s].
        feedforward: xdot_d (6,) [m/s, rad/s].
        damping_squared: d = l^2 > 0.
        q: the configuration (nq,); q_index, v_index: (m,) where the potential's coordinates sit in q and v.
        nullspace_scale: s = -alpha c_i / range_i^2 (m,); middle: the joints' mid-range (m,) [rad or m].
        scale: the factor on v written to ``out`` (a step's dt [s], or 1).
        error: (6,) written with e [m, rad].
        out: (nv,) written with scale * v.

    Returns:
        False when J J^T + d I is not numerically positive definite (``out`` is then not written).
    """
    rows, columns = jacobian.shape
    pose_error_norm(transform_frame_to_world, target_translation, rotation_error, error)
    z0 = np.zeros(columns)
    for entry in range(q_index.size):
        z0[v_index[entry]] = nullspace_scale[entry] * (q[q_index[entry]] - middle[entry])
    rhs = np.empty(rows)  # c - J z0
    for row in range(rows):
        value = gain * error[row] + feedforward[row]
        for col in range(columns):
            value -= jacobian[row, col] * z0[col]
        rhs[row] = value
    if not dls_solve_into(jacobian, rhs, damping_squared, out):
        return False
    for col in range(columns):  # z0 + J^+ (c - J z0)
        out[col] = scale * (z0[col] + out[col])
    return True
