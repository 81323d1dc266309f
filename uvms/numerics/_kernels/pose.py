"""Pose errors of a frame task: the Newton steps of ``uvms.solvers.ik`` and the rows of a prepared CLIK step.

The rotation R_d R^T whose log3 is the orientation error, the norm of the pose error e = [p_d - p; log3(R_d R^T)],
Pinocchio's log3, matrixToRpy and SE3.actInv themselves (ports, operation by operation) and a frame task's rows (its
Jacobian and its error, log or Euler) from the joint kinematics Pinocchio computed (``uvms.solvers.clik``).

The module imports numba, so it is loaded where a solver first uses it, not by ``import uvms``; its kernels
compile at their first call and are cached on disk (``cache=True``, see :mod:`uvms.numerics._kernels`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["action_into", "compose_into", "frame_rows_into", "inverse_action_into", "linear_at_point", "log3_into",
           "matrix_to_rpy", "pose_error_norm", "rotation_to_target", "row_product"]

EPSILON = np.finfo(np.float64).eps
#: Pinocchio's TaylorSeriesExpansion<double>::precision<2>(): eps^(1/3), where log3 switches to its expansions.
LOG3_PRECISION = EPSILON ** (1.0 / 3.0)


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
def theta_axis(value: float, rotation: np.ndarray, first: int) -> tuple[float, float, float, float]:
    """Pinocchio's ``internal::compute_theta_axis<first>``: (angle, unit axis (3 floats)) of a rotation near pi
    from its ``first`` diagonal entry's ``value`` = 2 R_ii - tr R + 1."""
    second, third = (first + 1) % 3, (first + 2) % 3
    sign = 1.0 if rotation[third, second] >= rotation[second, third] else -1.0
    s = np.sqrt(value + EPSILON + EPSILON * EPSILON) * sign  # keeps the root's argument >= 0 and s != 0
    axis = np.empty(3)
    axis[first] = s / 2.0
    axis[second] = 1.0 / (2.0 * s) * (rotation[second, first] + rotation[first, second])
    axis[third] = 1.0 / (2.0 * s) * (rotation[third, first] + rotation[first, third])
    w = 1.0 / (2.0 * s) * (rotation[third, second] - rotation[second, third])
    norm = np.sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2])
    return 2.0 * np.arctan2(norm, w), axis[0] / norm, axis[1] / norm, axis[2] / norm


@njit(cache=True)
def log3_into(rotation: np.ndarray, out: np.ndarray) -> None:
    """log3(R) (3,) [rad] of a rotation matrix R (3, 3), written to ``out``: Pinocchio's ``log3`` (spatial/log.hxx)
    operation by operation (R renormalized, the Taylor expansion near 0, the axis of the largest diagonal entry near
    pi), so that its numbers are Pinocchio's to rounding."""
    normed = np.empty((3, 3))  # renormalize_rotation_matrix: columns 0 and 1 unit, then two cross products
    for col in range(2):
        norm = np.sqrt(rotation[0, col] * rotation[0, col] + rotation[1, col] * rotation[1, col]
                       + rotation[2, col] * rotation[2, col])
        for row in range(3):
            normed[row, col] = rotation[row, col] / norm
    for target, left, right in ((2, 0, 1), (0, 1, 2)):
        normed[0, target] = normed[1, left] * normed[2, right] - normed[2, left] * normed[1, right]
        normed[1, target] = normed[2, left] * normed[0, right] - normed[0, left] * normed[2, right]
        normed[2, target] = normed[0, left] * normed[1, right] - normed[1, left] * normed[0, right]
    trace = normed[0, 0] + (normed[1, 1] + normed[2, 2])  # Eigen's unrolled sum: a + (b + c)
    cosine = (trace - 1.0) / 2.0
    if cosine < -1.0 + LOG3_PRECISION:  # near pi: the axis from the largest of 2 R_ii - tr R + 1
        values = np.empty(3)
        for index in range(3):
            values[index] = 2.0 * normed[index, index] - trace + 1.0
        first = (0 if values[0] >= values[2] else 2) if values[0] >= values[1] else (1 if values[1] >= values[2] else 2)
        theta, x, y, z = theta_axis(values[first], normed, first)
        out[0], out[1], out[2] = theta * x, theta * y, theta * z
        return
    expansion = np.sqrt(2.0 * (1.0 - cosine) + EPSILON * EPSILON)
    if trace <= 3.0 - LOG3_PRECISION:
        theta = np.arccos(cosine) if trace >= -1.0 + LOG3_PRECISION else np.pi - expansion
    else:
        theta = expansion
    x = 0.5 * (normed[2, 1] - normed[1, 2])  # unSkew
    y = 0.5 * (normed[0, 2] - normed[2, 0])
    z = 0.5 * (normed[1, 0] - normed[0, 1])
    squared = x * x + y * y + z * z
    if theta >= LOG3_PRECISION:
        t = theta / np.sin(theta)
    else:
        t = 1.0 + squared / 6.0 + squared * squared * 3.0 / 40.0
    out[0], out[1], out[2] = t * x, t * y, t * z


@njit(cache=True)
def matrix_to_rpy(rotation: np.ndarray) -> tuple[float, float, float]:
    """(roll, pitch, yaw) [rad] of R = Rz(yaw) Ry(pitch) Rx(roll): Pinocchio's ``rpy.matrixToRpy`` operation by
    operation (Eigen's ``eulerAngles(2, 1, 0)``, then pitch brought into [-pi/2, pi/2]), its numbers bit for bit."""
    yaw = np.arctan2(rotation[1, 0], rotation[0, 0])
    c2 = np.sqrt(rotation[2, 2] * rotation[2, 2] + rotation[2, 1] * rotation[2, 1])
    if yaw < 0.0:
        yaw += np.pi
        pitch = np.arctan2(-rotation[2, 0], -c2)
    else:
        pitch = np.arctan2(-rotation[2, 0], c2)
    s1, c1 = np.sin(yaw), np.cos(yaw)
    roll = np.arctan2(s1 * rotation[0, 2] - c1 * rotation[1, 2], c1 * rotation[1, 1] - s1 * rotation[0, 1])
    if pitch < -np.pi / 2:
        pitch += 2 * np.pi
    if pitch > np.pi / 2:
        pitch = np.pi - pitch
        roll = roll + np.pi if roll < 0.0 else roll - np.pi
        yaw -= np.pi
    return roll, pitch, yaw


@njit(cache=True)
def frame_rows_into(joint_jacobians: np.ndarray, joint_translation: np.ndarray, joint_rotation: np.ndarray,
                    placement: np.ndarray, columns: np.ndarray, rows: np.ndarray, target_translation: np.ndarray,
                    target_rotation: np.ndarray, target_rpy: np.ndarray, jacobian: np.ndarray,
                    error: np.ndarray) -> None:
    """The rows of a frame task (``uvms.tasks.frame``) at the joint kinematics Pinocchio computed.

    The frame's pose is oMi * placement (Pinocchio's SE3 product); its world-aligned Jacobian is that of
    ``getFrameJacobian`` (LOCAL_WORLD_ALIGNED): each column c of the joint's support is the world Jacobian's
    [v_c - p x w_c; w_c] (p the frame's position), every other column zero. The error is [p_d - p; log3(R_d R^T)]
    (world axes), or with ``target_rpy`` given [p_d - p; rpy_d - rpy wrapped to [-pi, pi)] with the angular rows
    E(rpy)^-1 w (rpy rates; E^-1 Pinocchio's ``computeRpyJacobianInverse`` in the world frame, each product summed
    in index order). Jacobian and error are kept on the task's ``rows``.

    Args:
        joint_jacobians: the joints' Jacobians in the world frame (6, nv) (Pinocchio's ``data.J``).
        joint_translation, joint_rotation: the placement oMi of the frame's joint, (3,) and (3, 3).
        placement: the frame's placement in its joint (4, 4), homogeneous.
        columns: the columns of v that move the joint (its support) (m,).
        rows: the task's rows among [x, y, z, roll, pitch, yaw] (k,).
        target_translation, target_rotation: p_d (3,) [m] and R_d (3, 3).
        target_rpy: rpy_d (3,) [rad] of the Euler error, or empty for the log error.
        jacobian: (k, nv) written; error: (k,) written [m, rad].
    """
    rotation = np.empty((3, 3))
    translation = np.empty(3)
    compose_into(joint_rotation, joint_translation, placement[:3, :3], placement[:3, 3], rotation, translation)
    full = np.empty(6)
    for axis in range(3):
        full[axis] = target_translation[axis] - translation[axis]
    euler = target_rpy.size > 0
    rates = np.zeros((3, 3))  # E(rpy)^-1, world frame
    if euler:
        roll, pitch, yaw = matrix_to_rpy(rotation)
        full[3] = (target_rpy[0] - roll + np.pi) % (2.0 * np.pi) - np.pi  # uvms wrap_angles
        full[4] = (target_rpy[1] - pitch + np.pi) % (2.0 * np.pi) - np.pi
        full[5] = (target_rpy[2] - yaw + np.pi) % (2.0 * np.pi) - np.pi
        sp, cp, sy, cy = np.sin(pitch), np.cos(pitch), np.sin(yaw), np.cos(yaw)
        tp = sp / cp
        rates[0, 0], rates[0, 1] = cy / cp, sy / cp
        rates[1, 0], rates[1, 1] = -sy, cy
        rates[2, 0], rates[2, 1], rates[2, 2] = cy * tp, sy * tp, 1.0
    else:
        relative = np.empty((3, 3))  # R_d R^T
        for row in range(3):
            for col in range(3):
                relative[row, col] = (target_rotation[row, 0] * rotation[col, 0]
                                      + target_rotation[row, 1] * rotation[col, 1]
                                      + target_rotation[row, 2] * rotation[col, 2])
        log3_into(relative, full[3:])
    for index in range(rows.size):  # columns off the support stay zero
        for col in range(jacobian.shape[1]):
            jacobian[index, col] = 0.0
    px, py, pz = translation[0], translation[1], translation[2]
    for index in range(rows.size):
        row = rows[index]
        error[index] = full[row]
        for col in columns:
            wx, wy, wz = joint_jacobians[3, col], joint_jacobians[4, col], joint_jacobians[5, col]
            if row < 3:
                jacobian[index, col] = linear_at_point(joint_jacobians, col, row, px, py, pz)
            elif euler:
                rate = rates[row - 3]
                jacobian[index, col] = (rate[0] * wx + rate[1] * wy) + rate[2] * wz
            else:
                jacobian[index, col] = joint_jacobians[row, col]


@njit(cache=True)
def linear_at_point(joint_jacobians: np.ndarray, col: int, row: int, px: float, py: float, pz: float) -> float:
    """Linear row ``row`` (0, 1 or 2) of column ``col`` of the world Jacobian (Pinocchio's ``data.J`` (6, nv)) moved
    to the point p = (px, py, pz) [m]: (v - p x w)[row], what ``getFrameJacobian`` (LOCAL_WORLD_ALIGNED) writes for a
    frame at p (its numbers: the cross product's two products, then the differences)."""
    wx, wy, wz = joint_jacobians[3, col], joint_jacobians[4, col], joint_jacobians[5, col]
    if row == 0:
        return joint_jacobians[0, col] - (py * wz - pz * wy)
    if row == 1:
        return joint_jacobians[1, col] - (pz * wx - px * wz)
    return joint_jacobians[2, col] - (px * wy - py * wx)


@njit(cache=True)
def inverse_action_into(rotation: np.ndarray, translation: np.ndarray, first: np.ndarray, second: np.ndarray,
                        out: np.ndarray, at_first: int, at_second: int) -> None:
    """out[at_first:+3] = R^T (first - p x second), out[at_second:+3] = R^T second: Pinocchio's ``SE3.actInv`` of a
    motion (first = v, second = w: at 0 and 3) or a force (first = n, second = f: at 3 and 0), each entry's sums in
    Eigen's order (its numbers, signed zeros included).

    Args:
        rotation: R (3, 3) and translation: p (3,) of the placement; first, second: (3,) each; out: (6,).
    """
    cross0 = translation[1] * second[2] - translation[2] * second[1]
    cross1 = translation[2] * second[0] - translation[0] * second[2]
    cross2 = translation[0] * second[1] - translation[1] * second[0]
    d0, d1, d2 = first[0] - cross0, first[1] - cross1, first[2] - cross2
    for i in range(3):
        out[at_first + i] = (rotation[0, i] * d0 + rotation[1, i] * d1) + rotation[2, i] * d2
        out[at_second + i] = (rotation[0, i] * second[0] + rotation[1, i] * second[1]) + rotation[2, i] * second[2]



@njit(cache=True)
def row_product(matrix: np.ndarray, row: int, x: float, y: float, z: float) -> float:
    """Row ``row`` of M (3, 3) times [x, y, z] as Eigen's fixed-size product M v sums it (Pinocchio's SE3
    arithmetic): rows 0 and 1 (one SIMD packet) as (m0 x + m1 y) + m2 z, row 2 (the remainder) as
    m0 x + (m1 y + m2 z)."""
    if row < 2:
        return (matrix[row, 0] * x + matrix[row, 1] * y) + matrix[row, 2] * z
    return matrix[row, 0] * x + (matrix[row, 1] * y + matrix[row, 2] * z)


@njit(cache=True)
def compose_into(rotation: np.ndarray, translation: np.ndarray, placement_rotation: np.ndarray,
                 placement_translation: np.ndarray, out_rotation: np.ndarray, out_translation: np.ndarray) -> None:
    """The pose (R R_p (3, 3), p + R p_p (3,) [m]) of a frame placed at (R_p, p_p) in a frame at (R, p): Pinocchio's
    SE3 product ``M * M_p``, each entry summed in Eigen's order (:func:`row_product`: its numbers, signed zeros
    included).

    Args:
        rotation, translation: R (3, 3) and p (3,); placement_rotation, placement_translation: R_p (3, 3) and
        p_p (3,); out_rotation: (3, 3) written; out_translation: (3,) written (neither one of the inputs).
    """
    for row in range(3):
        out_translation[row] = translation[row] + row_product(rotation, row, placement_translation[0],
                                                              placement_translation[1], placement_translation[2])
        for col in range(3):
            out_rotation[row, col] = row_product(rotation, row, placement_rotation[0, col],
                                                 placement_rotation[1, col], placement_rotation[2, col])


@njit(cache=True)
def action_into(rotation: np.ndarray, translation: np.ndarray, linear: np.ndarray, angular: np.ndarray,
                out: np.ndarray) -> None:
    """out = [R v + p x (R w); R w] (6,): Pinocchio's ``SE3.act`` of a motion [v; w] (R w, R v, then the cross
    product added; the products summed in Eigen's order, :func:`row_product`: its numbers, signed zeros included).

    Args:
        rotation: R (3, 3) and translation: p (3,) of the placement; linear: v (3,); angular: w (3,); out: (6,)
            written (not one of the inputs).
    """
    for i in range(3):
        out[3 + i] = row_product(rotation, i, angular[0], angular[1], angular[2])
        out[i] = row_product(rotation, i, linear[0], linear[1], linear[2])
    out[0] += translation[1] * out[5] - translation[2] * out[4]
    out[1] += translation[2] * out[3] - translation[0] * out[5]
    out[2] += translation[0] * out[4] - translation[1] * out[3]
