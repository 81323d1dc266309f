"""The distance Jacobian of pairs of shapes from their witness points, normals and joint Jacobians.

``uvms.model.distances``: the row of a pair is n^T (J_v,2 - J_v,1) - (n x p2)^T J_w,2 + (n x p1)^T J_w,1.

The module imports numba, so it is loaded where a distance Jacobian is first asked for, not by ``import uvms``;
its kernel compiles at its first call and is cached on disk (``cache=True``, see :mod:`uvms.numerics._kernels`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["distance_jacobian_into"]


@njit(cache=True)
def distance_jacobian_into(table: np.ndarray, entries: np.ndarray, normal: np.ndarray, point1: np.ndarray,
                           point2: np.ndarray, out: np.ndarray) -> None:
    """Rows (k, nv) of d' = J v, written to ``out``.

    Args:
        table: (u, 6, nv) joint Jacobians in the WORLD frame (linear velocity at the world origin, angular
            velocity); entries: (k, 2) int64, each side's entry in ``table`` (-1: the world, which does not move);
        normal: (k, 3) unit normals from side 0 to side 1; point1, point2: (k, 3) witness points [m].
    """
    out[:] = 0.0
    for row in range(entries.shape[0]):
        n = normal[row]
        for side in range(2):
            entry = entries[row, side]
            if entry < 0:
                continue
            p = point1[row] if side == 0 else point2[row]
            sign = -1.0 if side == 0 else 1.0
            m0 = n[1] * p[2] - n[2] * p[1]  # n x p
            m1 = n[2] * p[0] - n[0] * p[2]
            m2 = n[0] * p[1] - n[1] * p[0]
            jacobian = table[entry]
            for column in range(out.shape[1]):
                out[row, column] += sign * (n[0] * jacobian[0, column] + n[1] * jacobian[1, column]
                                            + n[2] * jacobian[2, column] - m0 * jacobian[3, column]
                                            - m1 * jacobian[4, column] - m2 * jacobian[5, column])
