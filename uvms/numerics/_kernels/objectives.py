"""The rows of geometric inequality objectives (``uvms.tasks.objectives.frames``) from the joint kinematics Pinocchio
computed (a frame's pose and Jacobian formed here in Pinocchio's arithmetic), or from the frame's own.

Each kernel writes an objective's Jacobian row, and with it the activation and the reference rate
(:func:`~.activation.activation_reference_into`), into arrays the caller owns (a solver's stacked rows), in numpy's
order: a product with one output row is ``np.dot`` (the BLAS routine numpy's ``@`` calls: its numbers), elementwise
arithmetic as numpy writes it. The vehicle's tilt itself stays numpy's ``arccos`` (numba's differs in the last bit).

The module imports numba, so it is loaded where an objective is first evaluated, not by ``import uvms``; its kernels
compile at their first call and are cached on disk (``cache=True``, see :mod:`uvms.numerics._kernels`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .activation import activation_reference_into
from .pose import compose_into, linear_at_point

__all__ = ["clearance_rows_into", "frame_rows_of", "tilt_rows_into"]


@njit(cache=True)
def frame_rows_of(jacobians: np.ndarray, columns: np.ndarray, first: int, at_point: bool, point: np.ndarray,
                  out: np.ndarray) -> None:
    """Three rows of a frame's world-aligned Jacobian into ``out`` (3, nv), C-ordered, zero off ``columns``.

    Args:
        jacobians: every joint's world Jacobian (Pinocchio's ``data.J``, 6 x nv) with ``at_point``: the linear rows
            (``first`` 0) moved to the frame's origin ``point`` (3,) [m] (:func:`~.pose.linear_at_point`), or the
            angular rows (``first`` 3) as they are; else the frame's own world-aligned Jacobian (6, nv), its rows
            ``first`` to ``first + 2`` copied.
        columns: the columns that move the frame (its joint's support), or every column.
    """
    for row in range(3):
        for col in range(out.shape[1]):
            out[row, col] = 0.0
    for col in columns:
        for row in range(3):
            if at_point and first == 0:
                out[row, col] = linear_at_point(jacobians, col, row, point[0], point[1], point[2])
            else:
                out[row, col] = jacobians[first + row, col]


@njit(cache=True)
def tilt_rows_into(x: float, y: float, tilt: np.ndarray, jacobians: np.ndarray, columns: np.ndarray,
                   level_tilt: float, bounds: np.ndarray, gain: float, step: bool, row: np.ndarray,
                   activation: np.ndarray, reference: np.ndarray) -> None:
    """The vehicle attitude's row d tilt / dt = -u . omega, u = (z_b x e_z) / |z_b x e_z|, and its activation.

    Args:
        x, y: the body z axis' world x and y [-] (z_b x e_z = (y, -x, 0), its length sin(tilt)).
        tilt: the tilt (1,) [rad] (numpy's arccos of the axis' z).
        jacobians, columns: the vehicle frame's angular rows, as :func:`frame_rows_of` reads them (the joints' world
            Jacobian and the frame's support, or the frame's own Jacobian and every column: the same rows).
        level_tilt: below this |z_b x e_z| the row is 0 (the gradient undefined at tilt 0).
        bounds, gain, step: the objective's (:func:`~.activation.activation_reference_into`).
        row: (nv,) written; activation, reference: (1,) written.
    """
    axis = np.empty(3)
    axis[0], axis[1], axis[2] = y, -x, 0.0
    length = np.sqrt(np.dot(axis, axis))  # numpy's norm of a vector: sqrt of its dot with itself
    if length < level_tilt:
        row[:] = 0.0
    else:
        for index in range(3):
            axis[index] /= length
        angular = np.empty((3, row.size))
        frame_rows_of(jacobians, columns, 3, False, axis, angular)  # (the angular rows: no point read)
        product = np.dot(axis, angular)  # u^T J_omega (nv,), numpy's ``axis @ J[3:]``
        for col in range(row.size):
            row[col] = -product[col]
    activation_reference_into(tilt, bounds, gain, step, activation, reference)


@njit(cache=True)
def clearance_rows_into(normal: np.ndarray, rotation: np.ndarray, translation: np.ndarray, placement: np.ndarray,
                        jacobians: np.ndarray, columns: np.ndarray, at_joint: bool, point: np.ndarray,
                        bounds: np.ndarray, gain: float, step: bool, value: np.ndarray, row: np.ndarray,
                        activation: np.ndarray, reference: np.ndarray) -> None:
    """A plane clearance's value n . (p - p0), its row n^T J_p and its activation.

    Args:
        normal: n (3,) unit.
        rotation, translation, placement, jacobians, columns, at_joint: with ``at_joint``, the frame's joint's
            placement (R (3, 3), t (3,)), the frame's placement in it (4, 4), every joint's world Jacobian and the
            joint's support: the frame's position p is Pinocchio's oMi * placement (:func:`~.pose.compose_into`) and
            J_p the Jacobian's linear rows moved to it; else p = ``translation`` and J_p the rows of the frame's own
            Jacobian (``rotation`` and ``placement`` unread).
        point: p0 (3,) [m].
        bounds, gain, step: the objective's (:func:`~.activation.activation_reference_into`).
        value: (1,) written [m]; row: (nv,) written; activation, reference: (1,) written.
    """
    position = np.empty(3)
    if at_joint:
        composed = np.empty((3, 3))
        compose_into(rotation, translation, placement[:3, :3], placement[:3, 3], composed, position)
    else:
        position[:] = translation
    offset = np.empty(3)
    for axis in range(3):
        offset[axis] = position[axis] - point[axis]
    value[0] = np.dot(normal, offset)
    linear = np.empty((3, row.size))
    frame_rows_of(jacobians, columns, 0, at_joint, position, linear)
    product = np.dot(normal, linear)  # numpy's ``normal @ J[:3]``
    for col in range(row.size):
        row[col] = product[col]
    activation_reference_into(value, bounds, gain, step, activation, reference)
