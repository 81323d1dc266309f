"""Dexterity per voxel: the fraction of the cells of SO(3) the samples in a voxel reach.

`dexterity_map` takes all samples at once; `DexterityAccumulator` takes them chunk by
chunk and keeps only the distinct (voxel, orientation cell) pairs, so its memory is
bounded by voxels x cells, not by the number of samples; both give the same map.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import WorkspaceInputError
from .batch import AXES, CHUNK
from .voxels import UniqueRows, check_points, check_voxel, voxel_indices


def equal_area_rings(count: int) -> tuple[np.ndarray, np.ndarray]:
    """An equal-area partition of the unit sphere into ``count`` cells, as rings of cells.

    Zonal construction after Leopardi's EQSP: a polar cap of one cell at each pole,
    then collars about one cell side wide (sqrt(4 pi / count)) each holding the
    number of cells that fits its area (rounded with carry-over so the total is
    exact); the collar boundaries are then moved so that every cell has area
    exactly 4 pi / count (by Archimedes, a zone's area is 2 pi times its height in z).

    Returns:
        (z_edges (R+1,) from +1 down to -1, cells per ring (R,)).
    """
    if count == 1:
        return np.array([1.0, -1.0]), np.array([1])
    if count == 2:
        return np.array([1.0, 0.0, -1.0]), np.array([1, 1])
    cap = np.arccos(1.0 - 2.0 / count)  # polar angle of a one-cell cap
    collars = max(1, round(float((np.pi - 2.0 * cap) / np.sqrt(4.0 * np.pi / count))))
    width = (np.pi - 2.0 * cap) / collars
    counts, carry = [1], 0.0
    for k in range(collars):
        ideal = (np.cos(cap + k * width) - np.cos(cap + (k + 1) * width)) * count / 2.0 + carry
        cells = max(1, round(float(ideal)))
        carry = ideal - cells
        counts.append(cells)
    counts[-1] += count - 1 - sum(counts)  # absorbs round-off so that the total is exact
    counts.append(1)
    counts = np.array(counts)
    z_edges = np.concatenate([[1.0], 1.0 - 2.0 * np.cumsum(counts) / count])
    z_edges[-1] = -1.0
    return z_edges, counts


#: The most approach-direction cells of an `OrientationGrid`: 1,000,000 (cells 0.2 deg across); the grid keeps
#: 9 numbers per cell, 72 MB at the bound (10^9 cells would be 72 GB).
MAX_DIRECTIONS = 1_000_000
#: The most roll bins: 36,000 (0.01 deg each), so that a cell index stays exact.
MAX_ROLL_BINS = 36_000


@dataclass(frozen=True)
class OrientationGrid:
    """Cells of the orientation space SO(3): equal-area cells of the approach direction x bins of the roll.

    The approach direction (one axis of the frame, a point of the unit sphere)
    falls in one of ``directions`` equal-area cells (`equal_area_rings`); the roll
    is the angle of the next frame axis (y after x, z after y, x after z) about the
    centre direction of that cell, measured from a fixed tangent basis of the cell,
    cut into ``roll_bins`` equal bins. The uniform (Haar) measure of SO(3) is the
    uniform measure of the approach direction times the uniform measure of the
    roll, so the cells have equal volume up to the tilt of the direction inside its
    cell (about 2 % for 100 cells). ``roll_bins=1`` measures approach directions only.

    Attributes:
        directions: number of approach-direction cells (1 .. `MAX_DIRECTIONS`). Default 100: cells about 20 deg
            across.
        roll_bins: number of roll bins (1 .. `MAX_ROLL_BINS`). Default 18: 20 deg each, matching the direction
            cells.
        approach: frame axis taken as the approach direction, "x", "y" or "z".
    """

    directions: int = 100
    roll_bins: int = 18
    approach: str = "z"
    z_edges: np.ndarray = field(init=False, repr=False, compare=False)  # (R+1,)
    ring_counts: np.ndarray = field(init=False, repr=False, compare=False)  # (R,)
    ring_offsets: np.ndarray = field(init=False, repr=False, compare=False)  # (R,)
    centres: np.ndarray = field(init=False, repr=False, compare=False)  # (directions, 3) unit
    tangents: np.ndarray = field(init=False, repr=False, compare=False)  # (directions, 2, 3) roll basis

    def __post_init__(self) -> None:
        for name, most in (("directions", MAX_DIRECTIONS), ("roll_bins", MAX_ROLL_BINS)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not 1 <= value <= most:
                raise WorkspaceInputError(f"OrientationGrid.{name} (--{name.replace('_', '-')}) must be an integer "
                                          f"in [1, {most:,}], got {value!r}")
        if self.approach not in AXES:
            raise WorkspaceInputError(f"approach axis must be one of x, y, z; got {self.approach!r}")
        z_edges, counts = equal_area_rings(int(self.directions))
        offsets = np.concatenate([[0], np.cumsum(counts)[:-1]])
        centres = []
        for ring, cells in enumerate(counts):
            if cells == 1 and ring in (0, len(counts) - 1):  # a polar cap: centred on its pole
                z = 1.0 if ring == 0 else -1.0
            else:
                z = 0.5 * (z_edges[ring] + z_edges[ring + 1])  # halves the ring's area
            longitude = -np.pi + (np.arange(cells) + 0.5) * 2.0 * np.pi / cells
            radius = np.sqrt(max(0.0, 1.0 - z * z))
            centres.append(np.column_stack([radius * np.cos(longitude), radius * np.sin(longitude),
                                            np.full(cells, z)]))
        centres = np.vstack(centres)
        reference = np.where(np.abs(centres[:, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
        first = np.cross(reference, centres)
        first /= np.linalg.norm(first, axis=1, keepdims=True)
        second = np.cross(centres, first)
        object.__setattr__(self, "z_edges", z_edges)
        object.__setattr__(self, "ring_counts", counts)
        object.__setattr__(self, "ring_offsets", offsets)
        object.__setattr__(self, "centres", centres)
        object.__setattr__(self, "tangents", np.stack([first, second], axis=1))

    @property
    def count(self) -> int:
        """Number of orientation cells: directions x roll_bins."""
        return int(self.directions) * int(self.roll_bins)

    def direction_cells(self, directions: np.ndarray) -> np.ndarray:
        """Cell index (N,) in [0, directions) of direction vectors (N, 3) (any non-zero length)."""
        vectors = np.asarray(directions, dtype=float)
        norms = np.linalg.norm(vectors, axis=1)
        z = np.clip(vectors[:, 2] / norms, -1.0, 1.0)
        ring = np.searchsorted(-self.z_edges[1:-1], -z, side="right")
        cells = self.ring_counts[ring]
        fraction = (np.arctan2(vectors[:, 1], vectors[:, 0]) + np.pi) / (2.0 * np.pi)
        return self.ring_offsets[ring] + np.minimum((fraction * cells).astype(np.int64), cells - 1)

    @property
    def axes(self) -> str:
        """The frame axes the cells depend on: the approach axis, then (with roll bins) the one after it."""
        following = "xyz"[(AXES[self.approach] + 1) % 3]
        return self.approach + following if self.roll_bins > 1 else self.approach

    def cells(self, rotations: np.ndarray) -> np.ndarray:
        """Orientation cell index (N,) in [0, count) of frame rotations (N, 3, 3) (columns: frame axes)."""
        rotations = np.asarray(rotations, dtype=float)
        if rotations.ndim != 3 or rotations.shape[1:] != (3, 3) or not np.all(np.isfinite(rotations)):
            raise WorkspaceInputError(f"rotations must be a finite (N, 3, 3) array, got shape {rotations.shape}")
        return self.cells_from_axes(np.stack([rotations[:, :, AXES[axis]] for axis in self.axes], axis=1))

    def cells_from_axes(self, axes: np.ndarray) -> np.ndarray:
        """Orientation cell index (N,) in [0, count) from the frame axes named by `axes`, unit vectors (N, k, 3)."""
        axes = np.asarray(axes, dtype=float)
        if axes.ndim != 3 or axes.shape[1:] != (len(self.axes), 3) or not np.all(np.isfinite(axes)):
            raise WorkspaceInputError(f"axes must be a finite (N, {len(self.axes)}, 3) array of the frame axes "
                                      f"{', '.join(self.axes)}, got shape {axes.shape}")
        bins = int(self.roll_bins)
        out = np.empty(axes.shape[0], dtype=np.int64)
        for start in range(0, axes.shape[0], CHUNK):
            chunk = axes[start:start + CHUNK]
            direction = self.direction_cells(chunk[:, 0])
            if bins == 1:
                out[start:start + CHUNK] = direction
                continue
            following = chunk[:, 1]  # (n, 3), perpendicular to the approach axis
            tangent = self.tangents[direction]  # (n, 2, 3)
            roll = np.arctan2(np.einsum("ij,ij->i", following, tangent[:, 1]),
                              np.einsum("ij,ij->i", following, tangent[:, 0]))
            roll_bin = np.minimum(((roll + np.pi) / (2.0 * np.pi) * bins).astype(np.int64), bins - 1)
            out[start:start + CHUNK] = direction * bins + roll_bin
        return out


@dataclass
class DexterityMap:
    """Dexterity of the occupied voxels: the fraction of the orientation cells reached in each.

    A Monte Carlo estimate from below: it grows with the samples and cannot exceed
    ``samples / cells`` in a voxel, so compare it across sample counts
    (`WorkspaceResult.dexterity_convergence`) before reading it as a property of the arm.
    An arm with fewer than 6 DOF reaches a lower-dimensional set of poses, so its
    dexterity tends to 0 as the cells shrink: that is a finding, not a bug.

    Attributes:
        centres: voxel centres (M, 3) [m].
        samples: samples that fell in each voxel (M,).
        reached: distinct orientation cells reached in each voxel (M,).
        cells: cells of the orientation grid.
        voxel: voxel edge [m].
    """

    centres: np.ndarray
    samples: np.ndarray
    reached: np.ndarray
    cells: int
    voxel: float

    @property
    def dexterity(self) -> np.ndarray:
        """Fraction (M,) in [0, 1] of the orientation cells reached in each voxel."""
        return self.reached / self.cells

    @property
    def mean(self) -> float:
        """Mean dexterity over the occupied voxels (the reachable volume); 0 when there are none."""
        return float(self.dexterity.mean()) if len(self.reached) else 0.0

    def volume(self, threshold: float) -> float:
        """Volume [m^3] of the voxels whose dexterity is >= threshold (the dexterous workspace at that level)."""
        if not (np.isfinite(threshold) and 0.0 <= threshold <= 1.0):
            raise WorkspaceInputError(f"a dexterity threshold must be in [0, 1], got {threshold!r}")
        return float(np.count_nonzero(self.dexterity >= threshold) * self.voxel**3)

    def summary(self, threshold: float = 0.9) -> dict:
        """Mean, max, voxel count, median samples per voxel and the dexterous volume at ``threshold``."""
        return {
            "mean": self.mean,
            "max": float(self.dexterity.max()) if len(self.reached) else 0.0,
            "voxels": len(self.reached),
            "median_samples_per_voxel": float(np.median(self.samples)) if len(self.samples) else 0.0,
            "threshold": float(threshold),
            "dexterous_volume": self.volume(threshold),
        }


class DexterityAccumulator:
    """Dexterity per voxel of a stream of samples: positions and orientation cells added chunk by chunk.

    Keeps the distinct (voxel, orientation cell) pairs with their sample counts, so
    memory is bounded by occupied voxels x ``total_cells`` whatever the number of
    samples; `map` gives the same `DexterityMap` as `dexterity_map` of all the samples.

    Args:
        voxel: voxel edge [m].
        total_cells: number of orientation cells (`OrientationGrid.count`).
    """

    def __init__(self, voxel: float, total_cells: int) -> None:
        self.voxel, self.total_cells = check_voxel(voxel), int(total_cells)
        self._pairs = UniqueRows(4, counted=True, what="(voxel, orientation cell) pairs")  # (ix, iy, iz, cell)

    def add(self, positions: np.ndarray, cells: np.ndarray) -> None:
        """Add sample positions (n, 3) [m] and their orientation cells (n,) in [0, total_cells)."""
        positions = check_points(positions, "positions")
        cells = np.asarray(cells)
        outside = cells.size and (cells.min() < 0 or cells.max() >= self.total_cells)
        if cells.shape != (positions.shape[0],) or outside:
            raise WorkspaceInputError(f"cells must be one integer in [0, {self.total_cells}) per position "
                                      f"({positions.shape[0]}), got shape {cells.shape}")
        if positions.shape[0]:
            self._pairs.add(np.column_stack([voxel_indices(positions, self.voxel), cells.astype(np.int64)]))

    def map(self) -> DexterityMap:
        """The dexterity of the samples added so far; voxels sorted by index (x first)."""
        pairs, counts = self._pairs.rows, self._pairs.counts  # (P, 4) sorted by voxel then cell, (P,)
        if pairs.shape[0] == 0:
            empty = np.empty(0, dtype=np.int64)
            return DexterityMap(np.empty((0, 3)), empty, empty, self.total_cells, self.voxel)
        new_voxel = np.ones(pairs.shape[0], dtype=bool)
        new_voxel[1:] = np.any(pairs[1:, :3] != pairs[:-1, :3], axis=1)
        starts = np.flatnonzero(new_voxel)  # first pair of each voxel
        reached = np.diff(np.append(starts, pairs.shape[0]))
        samples = np.add.reduceat(counts, starts)
        return DexterityMap((pairs[starts, :3] + 0.5) * self.voxel, samples, reached, self.total_cells, self.voxel)


def dexterity_map(positions: np.ndarray, cells: np.ndarray, voxel: float, total_cells: int) -> DexterityMap:
    """Dexterity per voxel from sample positions (N, 3) [m] and their orientation cells (N,) in [0, total_cells).

    The distinct (voxel, orientation cell) pairs are counted per voxel (`DexterityAccumulator` with one chunk).
    """
    accumulator = DexterityAccumulator(voxel, total_cells)
    accumulator.add(positions, cells)
    return accumulator.map()


def pose_dexterity(rotations: np.ndarray, positions: np.ndarray, voxel: float = 0.1,
              grid: OrientationGrid | None = None) -> DexterityMap:
    """Dexterity per voxel of frame poses: rotations (N, 3, 3), positions (N, 3) [m], voxel edge [m]."""
    grid = grid or OrientationGrid()
    return dexterity_map(positions, grid.cells(rotations), voxel, grid.count)

