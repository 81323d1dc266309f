"""Voxel occupancy: volumes of point clouds and the common volume of two, at once or streamed chunk by chunk.

`voxel_volume` and `common_volume` take whole clouds; `VoxelOccupancy` takes the points
chunk by chunk and keeps only the occupied voxels (memory bounded by their number, not by
the number of points), with the same results.
"""

from __future__ import annotations

import numpy as np

from ..errors import WorkspaceInputError
from ..numerics.validate import finite_array, positive_number


def check_voxel(voxel: float, what: str = "voxel size") -> float:
    """A voxel edge [m]: finite and > 0."""
    return positive_number(voxel, what, unit=" [m]", error=WorkspaceInputError)


def check_points(points: np.ndarray, what: str = "points") -> np.ndarray:
    """A finite (N, 3) float array [m]."""
    return finite_array(points, what, (None, 3), error=WorkspaceInputError, unit=" [m]")


def voxel_indices(points: np.ndarray, voxel: float) -> np.ndarray:
    """Integer voxel index (N, 3) of each point: floor(point / voxel), voxel edge [m]."""
    return np.floor(check_points(points) / check_voxel(voxel)).astype(np.int64)


def flat_keys(indices: np.ndarray, what: str = "points") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One int64 key per row of integer indices (N, k), ordered like the rows (C order).

    Args:
        indices: integer rows (N, k), N >= 1 (voxel indices, or voxel indices and an orientation cell).
        what: what the rows are, for the error message.

    Returns:
        (keys (N,), low (k,) the smallest index per column, span (k,) the index range per column);
        ``np.unravel_index(keys, span) + low`` gives the indices back.

    Raises:
        WorkspaceInputError: the rows span 2^62 or more keys (a voxel far too small for the points).
    """
    low = indices.min(axis=0)
    span = indices.max(axis=0) - low + 1
    if float(np.prod(span.astype(float))) >= 2.0**62:
        unit = "voxels per axis" if indices.shape[1] == 3 else "values per column"
        raise WorkspaceInputError(f"the {what} span {span.tolist()} {unit}, too many for 64-bit keys; "
                                  f"use a larger voxel")
    return np.ravel_multi_index(tuple((indices - low).T), tuple(int(n) for n in span)), low, span


#: A key range up to this many times the number of keys (and up to ``DENSE_KEYS``) is tallied in a dense
#: table (O(keys + range), no sort) instead of sorted; a sparse one goes through ``np.unique``.
DENSE_RATIO = 16
#: Largest key range tallied densely (a table of that many bytes, or 8x that for counts).
DENSE_KEYS = 1 << 24


def distinct_keys(keys: np.ndarray, key_range: int, counted: bool = False, counts: np.ndarray | None = None
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Sorted distinct keys (m,) of integer keys (n,) in [0, key_range), with their summed counts (m,) when ``counted``.

    Same result as ``np.unique(keys, return_counts=counted)`` (``counts`` (n,) weight each key; None: 1 each),
    by a dense table when the range is small enough (``DENSE_RATIO``, ``DENSE_KEYS``), else by ``np.unique``.
    """
    dense = key_range <= min(DENSE_KEYS, DENSE_RATIO * max(keys.size, 1) + 4096)
    if dense and not counted:
        table = np.zeros(key_range, dtype=bool)
        table[keys] = True
        return np.flatnonzero(table), np.empty(0, dtype=np.int64)
    if dense and key_range <= DENSE_KEYS // 8:
        tally = np.bincount(keys, weights=counts, minlength=key_range)
        unique = np.flatnonzero(tally)
        return unique, tally[unique].astype(np.int64)
    if not counted:
        return np.unique(keys), np.empty(0, dtype=np.int64)
    if counts is None:
        return np.unique(keys, return_counts=True)
    unique, inverse = np.unique(keys, return_inverse=True)
    totals = np.zeros(unique.shape[0], dtype=np.int64)
    np.add.at(totals, inverse.ravel(), counts)
    return unique, totals


class UniqueRows:
    """The distinct integer rows (M, k) of a stream of chunks (n, k), optionally with how often each occurred.

    Each chunk is reduced to its distinct rows at once; the reduced chunks are merged
    into the sorted set when they hold more rows than the set itself (or than
    ``MERGE_ROWS``), so memory stays within about twice the distinct rows plus one chunk
    and the total work is O(N log N) for N rows streamed.

    Attributes:
        width: k, the columns of a row.
        counted: whether occurrences are counted.
    """

    #: Reduced rows that may wait before a merge even when the set is smaller.
    MERGE_ROWS = 1 << 12

    def __init__(self, width: int, counted: bool = False, what: str = "points") -> None:
        self.width, self.counted, self.what = int(width), bool(counted), what
        self._rows = np.empty((0, self.width), dtype=np.int64)  # (M, k) sorted, distinct
        self._counts = np.empty(0, dtype=np.int64)  # (M,)
        self._pending: list[tuple[np.ndarray, np.ndarray]] = []
        self._pending_rows = 0

    def add(self, rows: np.ndarray) -> None:
        """Add integer rows (n, k); an empty chunk is ignored."""
        rows = np.asarray(rows, dtype=np.int64).reshape(-1, self.width)
        if rows.shape[0] == 0:
            return
        distinct, counts = self._distinct(rows)
        self._pending.append((distinct, counts))
        self._pending_rows += distinct.shape[0]
        if self._pending_rows >= max(self._rows.shape[0], self.MERGE_ROWS):
            self._merge()

    def _distinct(self, rows: np.ndarray, counts: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Distinct rows (m, k) sorted, with their summed counts (m,) (each row counts once when ``counts`` is None)."""
        keys, low, span = flat_keys(rows, self.what)
        unique, totals = distinct_keys(keys, int(np.prod(span)), self.counted, counts)
        distinct = np.column_stack(np.unravel_index(unique, tuple(int(n) for n in span))) + low
        return distinct.astype(np.int64, copy=False).reshape(-1, self.width), totals

    def _merge(self) -> None:
        if not self._pending:
            return
        rows = np.vstack([self._rows] + [rows for rows, _ in self._pending])
        counts = (np.concatenate([self._counts] + [counts for _, counts in self._pending]) if self.counted
                  else np.empty(0, dtype=np.int64))
        self._pending, self._pending_rows = [], 0
        self._rows, self._counts = self._distinct(rows, counts)

    @property
    def rows(self) -> np.ndarray:
        """The distinct rows (M, k), sorted (lexicographically, first column first)."""
        self._merge()
        return self._rows

    @property
    def counts(self) -> np.ndarray:
        """How often each of `rows` occurred (M,) (only when counted)."""
        if not self.counted:
            raise WorkspaceInputError("these rows are not counted (UniqueRows(counted=True) counts them)")
        self._merge()
        return self._counts

    def __len__(self) -> int:
        return int(self.rows.shape[0])


class VoxelOccupancy:
    """The occupied voxels of a stream of point chunks, edge ``voxel`` [m]: memory bounded by the occupied voxels.

    ``add`` chunk after chunk, then read `volume`, `keys` or `common_volume` (at any time:
    they describe the points added so far). The result equals `voxel_volume` of all the
    points at once, whatever the chunks.
    """

    def __init__(self, voxel: float) -> None:
        self.voxel = check_voxel(voxel)
        self._voxels = UniqueRows(3)

    def add(self, points: np.ndarray) -> None:
        """Add points (n, 3) [m]."""
        self._voxels.add(voxel_indices(points, self.voxel))

    @property
    def keys(self) -> np.ndarray:
        """Integer voxel indices (M, 3) of the occupied voxels, unique, sorted (as `voxel_keys`)."""
        return self._voxels.rows

    @property
    def count(self) -> int:
        """Number of occupied voxels."""
        return len(self._voxels)

    @property
    def volume(self) -> float:
        """Occupied-voxel volume [m^3] of the points added so far."""
        return float(self.count * self.voxel**3)

    def common_volume(self, other: VoxelOccupancy) -> float:
        """Volume [m^3] of the voxels occupied by both (same voxel edge), as `common_volume`."""
        if other.voxel != self.voxel:
            raise WorkspaceInputError(f"a common volume needs equal voxels, got {self.voxel} and {other.voxel} m")
        return shared_volume(self.keys, other.keys, self.voxel)


def voxel_keys(points: np.ndarray, voxel: float) -> np.ndarray:
    """Integer voxel indices (M, 3) of the occupied voxels of edge ``voxel`` [m], unique, sorted."""
    indices = voxel_indices(points, voxel)
    if indices.shape[0] == 0:
        return np.empty((0, 3), dtype=np.int64)
    keys, low, span = flat_keys(indices)
    unique, _ = distinct_keys(keys, int(np.prod(span)))
    return np.column_stack(np.unravel_index(unique, tuple(int(n) for n in span))) + low


def voxel_volume(points: np.ndarray, voxel: float) -> float:
    """Occupied-voxel volume [m^3] of a point cloud (N, 3) [m]."""
    return float(len(voxel_keys(points, voxel)) * check_voxel(voxel) ** 3)


def common_volume(first: np.ndarray, second: np.ndarray, voxel: float) -> float:
    """Volume [m^3] of the voxels occupied by both clouds (N1, 3), (N2, 3) [m] (the common workspace of two arms)."""
    return shared_volume(voxel_keys(first, voxel), voxel_keys(second, voxel), voxel)


def shared_volume(a: np.ndarray, b: np.ndarray, voxel: float) -> float:
    """Volume [m^3] of the voxels in both sets of unique voxel indices (M1, 3), (M2, 3), edge ``voxel`` [m]."""
    if len(a) == 0 or len(b) == 0:
        return 0.0
    keys, _, _ = flat_keys(np.vstack([a, b]))
    shared = np.intersect1d(keys[: len(a)], keys[len(a):], assume_unique=True)
    return float(len(shared) * check_voxel(voxel) ** 3)

