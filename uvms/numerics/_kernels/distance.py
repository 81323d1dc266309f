"""The distance Jacobian of pairs of shapes from their witness points, normals and joint Jacobians, and the bounds
of their distances from bounding spheres.

``uvms.model.distances``: the row of a pair is n^T (J_v,2 - J_v,1) - (n x p2)^T J_w,2 + (n x p1)^T J_w,1.

The module imports numba, so it is loaded where a distance Jacobian is first asked for, not by ``import uvms``;
its kernels compile at their first call and is cached on disk (``cache=True``, see :mod:`uvms.numerics._kernels`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["distance_jacobian_into", "sphere_bounds_into"]


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


@njit(cache=True)
def sphere_bounds_into(rotation: np.ndarray, translation: np.ndarray, carrier: np.ndarray, centres: np.ndarray,
                       radii: np.ndarray, sides: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> None:
    """Bounds |c1 - c2| - (r1 + r2) <= d <= |c1 - c2| + r1 + r2 (m,) [m] of pairs' distances from their shapes'
    bounding spheres.

    Args:
        rotation, translation: (j, 3, 3), (j, 3) placements of the joints carrying the shapes (world frame);
        carrier: (g,) each shape's joint in them; centres: (g, 3) sphere centres in their joint's frame [m];
        radii: (g,) [m], inf for an unbounded shape (its pairs' bounds: -inf, +inf); sides: (m, 2) each pair's
        shapes; lower, upper: (m,) written.
    """
    world = np.empty((centres.shape[0], 3))
    for shape in range(centres.shape[0]):
        joint = carrier[shape]
        for i in range(3):
            world[shape, i] = (rotation[joint, i, 0] * centres[shape, 0] + rotation[joint, i, 1] * centres[shape, 1]
                               + rotation[joint, i, 2] * centres[shape, 2] + translation[joint, i])
    for pair in range(sides.shape[0]):
        a, b = sides[pair, 0], sides[pair, 1]
        if not (np.isfinite(radii[a]) and np.isfinite(radii[b])):
            lower[pair], upper[pair] = -np.inf, np.inf
            continue
        gap = np.sqrt((world[a, 0] - world[b, 0]) ** 2 + (world[a, 1] - world[b, 1]) ** 2
                      + (world[a, 2] - world[b, 2]) ** 2)
        lower[pair], upper[pair] = gap - radii[a] - radii[b], gap + radii[a] + radii[b]
