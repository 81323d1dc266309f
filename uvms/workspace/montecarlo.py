"""Monte Carlo workspace of one or more frames: sampling, volumes, hull removal, dexterity."""

from __future__ import annotations

import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import WorkspaceInputError
from ..robot import Robot
from .batch import CHUNK, BatchKinematics
from .dexterity import DexterityMap, OrientationGrid, dexterity_map
from .hull import HullShape, hull_shapes, outside_hull
from .voxels import check_voxel, common_volume, voxel_volume

with warnings.catch_warnings():  # tqdm.auto warns in notebooks without ipywidgets, then falls back to text
    warnings.simplefilter("ignore")
    from tqdm.auto import tqdm


@dataclass
class WorkspaceResult:
    """Monte Carlo workspace of one or more frames, points in the vehicle frame.

    Attributes:
        frames: frame names; samples: samples per frame.
        joints: sampled joint values per frame (N, n_f); positions: (N, 3) per frame [m].
        volume: occupied-voxel volume per frame [m^3]; common_volume: shared by the first two frames (or None).
        voxel: voxel edge [m]; samples_per_second: samples per second of batched FK (with the
            orientation binning when dexterity is computed).
        convergence: per frame, [(samples, volume)] at N/8, N/4, N/2, N.
        hull: the vehicle solids removed (None: not removed).
        outside_hull: per frame, (N,) True for the samples outside the hull (None: not removed).
        volume_outside_hull: per frame, occupied-voxel volume of the samples outside the hull [m^3].
        common_volume_outside_hull: the same for the common workspace [m^3].
        orientation_grid: the orientation cells of the dexterity (None: not computed).
        dexterity: per frame, the dexterity per voxel (of the samples outside the hull if removed).
        dexterity_convergence: per frame, [(samples, mean dexterity)] at N/4, N/2, N.
    """

    frames: list[str]
    samples: int
    joints: dict[str, np.ndarray]
    positions: dict[str, np.ndarray]
    volume: dict[str, float]
    common_volume: float | None
    voxel: float
    samples_per_second: float
    convergence: dict[str, list[tuple[int, float]]]
    hull: list[HullShape] | None = None
    outside_hull: dict[str, np.ndarray] | None = None
    volume_outside_hull: dict[str, float] | None = None
    common_volume_outside_hull: float | None = None
    orientation_grid: OrientationGrid | None = None
    dexterity: dict[str, DexterityMap] | None = None
    dexterity_convergence: dict[str, list[tuple[int, float]]] | None = None

    def cloud(self, frame: str, count: int | None = None) -> np.ndarray:
        """Positions (K, 3) [m] of the first ``count`` samples (default all) of a frame, hull removed if it was."""
        if frame not in self.positions:
            raise WorkspaceInputError(f"no samples of frame {frame!r}; valid: {', '.join(self.frames)}")
        count = self.samples if count is None else count
        if not 1 <= count <= self.samples:
            raise WorkspaceInputError(f"a sample count must be in [1, {self.samples}], got {count}")
        points = self.positions[frame][:count]
        return points if self.outside_hull is None else points[self.outside_hull[frame][:count]]

    def metrics(self, threshold: float = 0.9) -> dict:
        """The numbers of the run as plain JSON types (what ``uvms workspace`` writes to metrics.json)."""
        common = {"common": self.common_volume} if self.common_volume is not None else {}
        metrics = {
            "frames": list(self.frames), "samples": self.samples, "voxel": self.voxel,
            "volume": {**self.volume, **common},
            "volume_convergence": {frame: [[n, v] for n, v in series] for frame, series in self.convergence.items()},
            "samples_per_second": self.samples_per_second,
        }
        if self.hull is not None:
            common = ({"common": self.common_volume_outside_hull}
                      if self.common_volume_outside_hull is not None else {})
            metrics["volume_outside_hull"] = {**self.volume_outside_hull, **common}
            metrics["hull"] = [{"link": shape.link, "kind": shape.kind, "size": shape.size.tolist(),
                                "centre": shape.centre.tolist(), "volume": shape.volume} for shape in self.hull]
            metrics["fraction_inside_hull"] = {frame: 1.0 - float(mask.mean())
                                               for frame, mask in self.outside_hull.items()}
        if self.dexterity is not None:
            grid = self.orientation_grid
            metrics["dexterity"] = {
                "voxel": next(iter(self.dexterity.values())).voxel, "approach": grid.approach,
                "directions": int(grid.directions), "roll_bins": int(grid.roll_bins), "cells": grid.count,
                "frames": {frame: {**dexterity_.summary(threshold),
                                   "convergence": [[n, m] for n, m in self.dexterity_convergence[frame]]}
                           for frame, dexterity_ in self.dexterity.items()},
            }
        return metrics


def monte_carlo(
    robot: Robot,
    frames: Sequence[str],
    samples: int,
    *,
    seed: int | None = 0,
    voxel: float = 0.05,
    progress: bool | None = None,
    remove_hull: bool | Sequence[HullShape] = False,
    dexterity: bool | OrientationGrid = False,
    dexterity_voxel: float = 0.1,
) -> WorkspaceResult:
    """Sample each frame's joints uniformly, compute the poses in batch, measure volumes (and dexterity).

    Args:
        robot: the model; points are in its vehicle frame (the world for a fixed base).
        frames: frame names; the common workspace is that of the first two.
        samples: joint samples per frame (>= 1).
        seed: random seed (one generator for all frames, in order).
        voxel: voxel edge for the volumes [m].
        progress: progress bar over the samples (None: only on a terminal).
        remove_hull: True to drop the samples inside the vehicle's solids (`hull_shapes`),
            or the solids to use; the volumes and dexterity outside the hull are added.
        dexterity: True (default `OrientationGrid`) or a grid to measure the dexterity per voxel.
        dexterity_voxel: voxel edge for the dexterity [m]; coarser than ``voxel`` because each
            voxel needs many samples to fill its orientation cells.

    Returns:
        The WorkspaceResult.

    Raises:
        WorkspaceInputError: no frames, bad sample count or voxel, no hull geometry;
        FrameNotFound: an unknown frame.
    """
    frames = list(frames)
    if not frames:
        raise WorkspaceInputError("give at least one end-effector frame")
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or samples < 1:
        raise WorkspaceInputError(f"the sample count must be an integer >= 1, got {samples!r}")
    voxel, dexterity_voxel = check_voxel(voxel), check_voxel(dexterity_voxel, "dexterity voxel size")
    hull = None
    if remove_hull is True:
        hull = hull_shapes(robot)
    elif remove_hull is not False and remove_hull is not None:
        hull = [remove_hull] if isinstance(remove_hull, HullShape) else list(remove_hull)
    grid = OrientationGrid() if dexterity is True else (dexterity or None)
    batches = [BatchKinematics(robot, frame) for frame in frames]  # unknown frames fail before any work
    rng = np.random.default_rng(seed)
    joints, positions, volume, convergence = {}, {}, {}, {}
    outside, volume_outside, dexterity_maps, dexterity_convergence = {}, {}, {}, {}
    elapsed = 0.0
    bar = tqdm(total=samples * len(frames), disable=(not progress) if progress is not None else None,
               desc="workspace", unit="sample", unit_scale=True, leave=False)
    try:
        for frame, batch in zip(frames, batches):
            values = batch.sample(samples, rng)
            points = np.empty((samples, 3))
            cells = np.empty(samples, dtype=np.int64) if grid is not None else None
            for start in range(0, samples, CHUNK):
                part = slice(start, min(start + CHUNK, samples))
                started = time.perf_counter()
                if grid is None:
                    points[part] = batch.positions(values[part])
                else:
                    points[part], axes = batch.positions_and_axes(values[part], grid.axes)
                    cells[part] = grid.cells_from_axes(axes)
                elapsed += time.perf_counter() - started
                bar.update(part.stop - part.start)
            joints[frame], positions[frame] = values, points
            volume[frame] = voxel_volume(points, voxel)
            counts = sorted({max(1, samples // 8), max(1, samples // 4), max(1, samples // 2), samples})
            convergence[frame] = [(n, voxel_volume(points[:n], voxel)) for n in counts]
            kept = np.ones(samples, dtype=bool)
            if hull is not None:
                kept = outside[frame] = outside_hull(points, hull)
                volume_outside[frame] = voxel_volume(points[kept], voxel)
            if grid is not None:
                series = []
                for n in sorted({max(1, samples // 4), max(1, samples // 2), samples}):
                    mask = kept[:n]
                    series.append((n, dexterity_map(points[:n][mask], cells[:n][mask], dexterity_voxel, grid.count)))
                dexterity_maps[frame] = series[-1][1]
                dexterity_convergence[frame] = [(n, map_.mean) for n, map_ in series]
    finally:
        bar.close()
    shared = shared_outside = None
    if len(frames) >= 2:
        first, second = frames[:2]
        shared = common_volume(positions[first], positions[second], voxel)
        if hull is not None:
            shared_outside = common_volume(positions[first][outside[first]], positions[second][outside[second]], voxel)
    return WorkspaceResult(
        frames, samples, joints, positions, volume, shared, voxel, samples * len(frames) / max(elapsed, 1e-12),
        convergence, hull=hull, outside_hull=outside if hull is not None else None,
        volume_outside_hull=volume_outside if hull is not None else None,
        common_volume_outside_hull=shared_outside, orientation_grid=grid,
        dexterity=dexterity_maps if grid is not None else None,
        dexterity_convergence=dexterity_convergence if grid is not None else None)
