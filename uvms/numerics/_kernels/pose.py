"""Pose errors of one 6-D pose task (the Newton steps of ``uvms.solvers.ik``).

The rotation R_d R^T whose log3 is the orientation error, and the norm of the pose error
e = [p_d - p; log3(R_d R^T)].

The module imports numba, so it is loaded where a solver first uses it, not by ``import uvms``; its kernels
compile at their first call and are cached on disk (``cache=True``, see :mod:`uvms.numerics._kernels`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["pose_error_norm", "rotation_to_target"]


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
