"""Voxel occupancy: volumes of point clouds and the common volume of two."""

from __future__ import annotations

import numpy as np

from ..errors import WorkspaceInputError


def check_voxel(voxel: float, what: str = "voxel size") -> float:
    """A voxel edge [m]: finite and > 0."""
    if not (isinstance(voxel, (int, float, np.floating, np.integer)) and np.isfinite(voxel) and voxel > 0):
        raise WorkspaceInputError(f"{what} must be a finite number > 0 [m], got {voxel!r}")
    return float(voxel)


def check_points(points: np.ndarray, what: str = "points") -> np.ndarray:
    """A finite (N, 3) float array."""
    array = np.asarray(points, dtype=float)
    if array.ndim != 2 or array.shape[1] != 3 or not np.all(np.isfinite(array)):
        raise WorkspaceInputError(f"{what} must be a finite (N, 3) array [m], got shape {array.shape}")
    return array


def voxel_indices(points: np.ndarray, voxel: float) -> np.ndarray:
    """Integer voxel index (N, 3) of each point: floor(point / voxel), voxel edge [m]."""
    return np.floor(check_points(points) / check_voxel(voxel)).astype(np.int64)


def flat_keys(indices: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One int64 key per row of integer indices (N, 3), ordered like the rows (C order).

    Returns:
        (keys (N,), low (3,) the smallest index per axis, span (3,) the index range per axis);
        ``np.unravel_index(keys, span) + low`` gives the indices back.
    """
    low = indices.min(axis=0)
    span = indices.max(axis=0) - low + 1
    if float(np.prod(span.astype(float))) >= 2.0**62:
        raise WorkspaceInputError(f"the points span {span.tolist()} voxels per axis, too many for 64-bit keys; "
                                  f"use a larger voxel")
    return np.ravel_multi_index(tuple((indices - low).T), tuple(int(n) for n in span)), low, span


def voxel_keys(points: np.ndarray, voxel: float) -> np.ndarray:
    """Integer voxel indices (M, 3) of the occupied voxels of edge ``voxel`` [m], unique, sorted."""
    indices = voxel_indices(points, voxel)
    if indices.shape[0] == 0:
        return np.empty((0, 3), dtype=np.int64)
    keys, low, span = flat_keys(indices)
    return np.column_stack(np.unravel_index(np.unique(keys), tuple(int(n) for n in span))) + low


def voxel_volume(points: np.ndarray, voxel: float) -> float:
    """Occupied-voxel volume [m^3] of a point cloud (N, 3) [m]."""
    return float(len(voxel_keys(points, voxel)) * check_voxel(voxel) ** 3)


def common_volume(first: np.ndarray, second: np.ndarray, voxel: float) -> float:
    """Volume [m^3] of the voxels occupied by both clouds (N1, 3), (N2, 3) [m] (the common workspace of two arms)."""
    a, b = voxel_keys(first, voxel), voxel_keys(second, voxel)
    if len(a) == 0 or len(b) == 0:
        return 0.0
    keys, _, _ = flat_keys(np.vstack([a, b]))
    shared = np.intersect1d(keys[: len(a)], keys[len(a):], assume_unique=True)
    return float(len(shared) * check_voxel(voxel) ** 3)


# ---------------------------------------------------------------------------------------------- dexterity

#: Frame axes that can be the approach direction, and their column in a rotation matrix.
