"""The rows of geometric inequality objectives (``uvms.tasks.objectives.frames``) from a frame's pose and Jacobian.

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

__all__ = ["clearance_rows_into", "tilt_rows_into"]


@njit(cache=True)
def tilt_rows_into(x: float, y: float, tilt: np.ndarray, frame_jacobian: np.ndarray, level_tilt: float,
                   bounds: np.ndarray, gain: float, step: bool, row: np.ndarray, activation: np.ndarray,
                   reference: np.ndarray) -> None:
    """The vehicle attitude's row d tilt / dt = -u . omega, u = (z_b x e_z) / |z_b x e_z|, and its activation.

    Args:
        x, y: the body z axis' world x and y [-] (z_b x e_z = (y, -x, 0), its length sin(tilt)).
        tilt: the tilt (1,) [rad] (numpy's arccos of the axis' z).
        frame_jacobian: the vehicle frame's world-aligned Jacobian (6, nv) (its angular rows are read).
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
        product = np.dot(axis, frame_jacobian[3:])  # u^T J_omega (nv,), numpy's ``axis @ J[3:]``
        for col in range(row.size):
            row[col] = -product[col]
    activation_reference_into(tilt, bounds, gain, step, activation, reference)


@njit(cache=True)
def clearance_rows_into(normal: np.ndarray, translation: np.ndarray, point: np.ndarray, frame_jacobian: np.ndarray,
                        bounds: np.ndarray, gain: float, step: bool, value: np.ndarray, row: np.ndarray,
                        activation: np.ndarray, reference: np.ndarray) -> None:
    """A plane clearance's value n . (p - p0), its row n^T J_p and its activation.

    Args:
        normal: n (3,) unit; translation: the frame's position p (3,) [m]; point: p0 (3,) [m].
        frame_jacobian: the frame's world-aligned Jacobian (6, nv) (its linear rows are read).
        bounds, gain, step: the objective's (:func:`~.activation.activation_reference_into`).
        value: (1,) written [m]; row: (nv,) written; activation, reference: (1,) written.
    """
    offset = np.empty(3)
    for axis in range(3):
        offset[axis] = translation[axis] - point[axis]
    value[0] = np.dot(normal, offset)
    product = np.dot(normal, frame_jacobian[:3])  # numpy's ``normal @ J[:3]``
    for col in range(row.size):
        row[col] = product[col]
    activation_reference_into(value, bounds, gain, step, activation, reference)
