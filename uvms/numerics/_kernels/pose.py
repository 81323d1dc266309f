"""Pose errors and the DLS velocity of one 6-D pose task (``uvms.solvers.ik``).

The rotation R_d R^T whose log3 is the orientation error, the pose error e = [p_d - p; log3(R_d R^T)] and
its norm, and the DLS CLIK of a pose task with the joint-limit null-space motion.

The module imports numba, so it is loaded where a solver first uses it, not by ``import uvms``; its kernels
compile at their first call and are cached on disk (``cache=True``, see :mod:`uvms.numerics._kernels`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .clik import joint_limit_motion_into
from .dense import dls_solve_into

__all__ = ["dls_pose_velocity", "pose_error_norm", "rotation_to_target"]


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
    weights: np.ndarray,
    middle: np.ndarray,
    range_squared: np.ndarray,
    alpha: float,
    scale: float,
    error: np.ndarray,
    out: np.ndarray,
) -> bool:
    """scale * v (nv,) of the DLS CLIK of one 6-D pose task with a joint-limit null-space motion.

        e = [p_d - p; log3(R_d R^T)],  c = K e + xdot_d,  z0 = -alpha dS/dv (:func:`~.clik.joint_limit_motion_into`)
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
        q: the configuration (nq,).
        q_index, v_index, weights, middle, range_squared, alpha: the potential's ``NullspaceTerms``.
        scale: the factor on v written to ``out`` (a step's dt [s], or 1).
        error: (6,) written with e [m, rad].
        out: (nv,) written with scale * v.

    Returns:
        False when J J^T + d I is not numerically positive definite (``out`` is then not written).
    """
    rows, columns = jacobian.shape
    pose_error_norm(transform_frame_to_world, target_translation, rotation_error, error)
    z0 = np.empty(columns)
    joint_limit_motion_into(q, q_index, v_index, weights, middle, range_squared, alpha, z0)
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
