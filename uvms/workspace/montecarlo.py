"""Monte Carlo workspace of one or more frames: sampling, volumes, hull removal, dexterity, streamed in chunks.

The joint samples of a frame are drawn, transformed and binned ``CHUNK`` at a time;
only the occupied voxels (`VoxelOccupancy`), the distinct (voxel, orientation cell)
pairs (`DexterityAccumulator`) and the first ``POINTS_KEPT`` samples are kept, so memory
is bounded by the chunk, the occupied voxels and that subsample, whatever the sample
count. Drawing the chunks one after the other from one numpy Generator gives the same
uniform numbers as one big draw, so a seed gives the same result whatever the chunk size.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import WorkspaceInputError
from ..io.progress import tqdm
from ..robot.robot import Robot
from .batch import CHUNK, BatchKinematics
from .convergence import CONVERGENCE_TOLERANCE, VolumeConvergence, volume_convergence
from .dexterity import DexterityAccumulator, DexterityMap, OrientationGrid
from .hull import HullShape, hull_shapes, outside_hull
from .voxels import VoxelOccupancy, check_voxel

#: Samples per frame whose joint values and positions are kept (`WorkspaceResult.joints`/``positions``,
#: ``points.npz``, the scatter figures): the first ones drawn, a uniform random subsample since the draws are
#: i.i.d. About 13 MB per frame; volumes, convergence and dexterity always use every sample.
POINTS_KEPT = 200_000


def check_sample_count(samples: int) -> int:
    """A sample count: an integer >= 1 (bool and float refused), as an ``int``."""
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or samples < 1:
        raise WorkspaceInputError(f"the sample count must be an integer >= 1, got {samples!r}")
    return int(samples)


def check_seed(seed: int | None) -> int | None:
    """A random seed: None (fresh entropy) or an integer >= 0, what ``numpy.random.default_rng`` takes.

    Raises:
        WorkspaceInputError: a negative number, a bool or anything that is not an integer.
    """
    if seed is None:
        return None
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise WorkspaceInputError(f"the random seed must be an integer >= 0 (e.g. 0 or 12345), got {seed!r}")
    return int(seed)


def parse_sample_count(text: str | int) -> int:
    """A sample count from the command line: ``"1000000"``, ``"1_000_000"`` or ``"1e9"`` (an integral number) >= 1."""
    if isinstance(text, str):
        cleaned = text.strip().replace("_", "")
        try:
            value = int(cleaned)
        except ValueError:
            try:
                number = float(cleaned)
            except ValueError:
                number = math.nan
            if not (math.isfinite(number) and number.is_integer()):
                raise WorkspaceInputError(f"the sample count must be an integer >= 1 (e.g. 100000 or 1e6), "
                                          f"got {text!r}") from None
            value = int(number)
        return check_sample_count(value)
    return check_sample_count(text)


def chunk_spans(samples: int, chunk: int, cuts: Sequence[int] = ()) -> Iterator[tuple[int, int]]:
    """Consecutive sample ranges (start, stop) covering [0, samples), at most ``chunk`` long, cut at every ``cuts``."""
    start = 0
    for stop in sorted({*(cut for cut in cuts if 0 < cut < samples), samples}):
        while start < stop:
            end = min(start + chunk, stop)
            yield start, end
            start = end


@dataclass
class WorkspaceResult:
    """Monte Carlo workspace of one or more frames, points in the vehicle frame.

    Attributes:
        frames: frame names; samples: samples per frame (all of them count in the volumes and dexterity).
        joints: per frame, the joint values (K, n_f) [rad or m] of the first K = min(samples, keep_points)
            samples (`POINTS_KEPT` by default); positions: their frame positions (K, 3) [m].
        volume: occupied-voxel volume per frame [m^3]; common_volume: shared by the first two frames (or None).
        voxel: voxel edge [m]; samples_per_second: samples per second of batched FK (with the
            orientation binning when dexterity is computed).
        convergence: per frame, [(samples, volume)] at N/8, N/4, N/2, N.
        hull: the vehicle solids removed (None: not removed).
        outside_hull: per frame, (K,) True for the kept samples outside the hull (None: not removed).
        volume_outside_hull: per frame, occupied-voxel volume of the samples outside the hull [m^3].
        common_volume_outside_hull: the same for the common workspace [m^3].
        orientation_grid: the orientation cells of the dexterity (None: not computed).
        dexterity: per frame, the dexterity per voxel (of the samples outside the hull if removed).
        dexterity_convergence: per frame, [(samples, mean dexterity)] at N/4, N/2, N.
        samples_outside_hull: per frame, how many of all the samples lie outside the hull (None: not removed).
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
    samples_outside_hull: dict[str, int] | None = None

    def stored(self, frame: str) -> int:
        """How many samples of a frame have their joints and positions kept (the first ones drawn)."""
        if frame not in self.positions:
            raise WorkspaceInputError(f"no samples of frame {frame!r}; valid: {', '.join(self.frames)}")
        return len(self.positions[frame])

    def cloud(self, frame: str, count: int | None = None) -> np.ndarray:
        """Positions (K, 3) [m] of the first ``count`` samples (default: all kept) of a frame, hull removed if it was.

        Raises:
            WorkspaceInputError: an unknown frame, or ``count`` outside [1, samples] or beyond the kept samples.
        """
        kept = self.stored(frame)
        count = kept if count is None else count
        if not 1 <= count <= self.samples:
            raise WorkspaceInputError(f"a sample count must be in [1, {self.samples}], got {count}")
        if count > kept:
            raise WorkspaceInputError(f"only the first {kept} of the {self.samples} samples of {frame!r} are kept "
                                      f"(monte_carlo(keep_points=...)); ask for at most {kept}, got {count}")
        points = self.positions[frame][:count]
        return points if self.outside_hull is None else points[self.outside_hull[frame][:count]]

    def volume_converged(self, tolerance: float = CONVERGENCE_TOLERANCE) -> dict[str, VolumeConvergence]:
        """Per frame, whether its volume has converged: change over the last doubling <= ``tolerance`` [-]."""
        return {frame: volume_convergence(series, tolerance) for frame, series in self.convergence.items()}

    def metrics(self, threshold: float = 0.9, tolerance: float = CONVERGENCE_TOLERANCE) -> dict:
        """The numbers of the run as plain JSON types (what ``uvms workspace`` writes to metrics.json).

        Besides the volumes, convergence (``volume_converged``: per frame the verdict of
        :func:`~uvms.workspace.convergence.volume_convergence` at ``tolerance``), hull and dexterity:
        ``points_sampled`` and ``points_stored`` (per frame, samples drawn and samples whose joints and
        positions are kept) and ``points_note`` (a sentence saying what was kept).
        """
        common = {"common": self.common_volume} if self.common_volume is not None else {}
        stored = {frame: self.stored(frame) for frame in self.frames}
        kept = min(stored.values())
        note = (f"all {self.samples} samples of each frame are kept" if kept == self.samples else
                f"joints and positions (points.npz, scatter figures) are kept for the first {kept} of the "
                f"{self.samples} samples of each frame, a uniform random subsample (the samples are i.i.d.); "
                f"volumes, convergence, hull fractions and dexterity use all {self.samples}")
        metrics = {
            "frames": list(self.frames), "samples": self.samples, "voxel": self.voxel,
            "volume": {**self.volume, **common},
            "volume_convergence": {frame: [[n, v] for n, v in series] for frame, series in self.convergence.items()},
            "volume_converged": {frame: verdict.as_dict()
                                 for frame, verdict in self.volume_converged(tolerance).items()},
            "samples_per_second": self.samples_per_second,
            "points_sampled": {frame: self.samples for frame in self.frames},
            "points_stored": stored,
            "points_note": note,
        }
        if self.hull is not None:
            common = ({"common": self.common_volume_outside_hull}
                      if self.common_volume_outside_hull is not None else {})
            metrics["volume_outside_hull"] = {**self.volume_outside_hull, **common}
            metrics["hull"] = [{"link": shape.link, "kind": shape.kind, "size": shape.size.tolist(),
                                "centre": shape.centre.tolist(), "volume": shape.volume} for shape in self.hull]
            if self.samples_outside_hull is not None:  # counted over all the samples
                fractions = {frame: 1.0 - count / self.samples for frame, count in self.samples_outside_hull.items()}
            else:
                fractions = {frame: 1.0 - float(mask.mean()) for frame, mask in self.outside_hull.items()}
            metrics["fraction_inside_hull"] = fractions
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


@dataclass
class FrameStream:
    """What the streamed samples of one frame leave behind (bounded memory), see `stream_frame`."""

    joints: np.ndarray  # (K, n_f) the first K samples
    positions: np.ndarray  # (K, 3) [m]
    outside: np.ndarray | None  # (K,) bool
    occupancy: VoxelOccupancy
    occupancy_outside: VoxelOccupancy | None
    samples_outside: int
    dexterity: DexterityMap | None
    convergence: list[tuple[int, float]]
    dexterity_convergence: list[tuple[int, float]]
    elapsed: float  # [s] in batched FK and orientation binning


def stream_frame(batch: BatchKinematics, samples: int, rng: np.random.Generator, *, chunk: int, keep: int,
                 voxel: float, hull: list[HullShape] | None = None, grid: OrientationGrid | None = None,
                 dexterity_voxel: float = 0.1, bar=None) -> FrameStream:
    """Draw ``samples`` joint samples of one frame ``chunk`` at a time from ``rng`` and accumulate their statistics.

    Args:
        batch: the frame's batched kinematics; rng: the generator (the next uniform numbers are used).
        samples: joint samples (>= 1); chunk: samples drawn and processed at once (>= 1).
        keep: how many of the first samples keep their joints and positions (>= 0).
        voxel: voxel edge for the volumes [m]; dexterity_voxel: for the dexterity [m].
        hull: solids whose inner samples are left out of the "outside" volume and the dexterity (None: none).
        grid: orientation cells of the dexterity (None: no dexterity).
        bar: a tqdm bar advanced by the samples of each chunk (None: none).

    Returns:
        The FrameStream; memory is O(chunk + keep + occupied voxels (x cells)), not O(samples).
    """
    kept = min(samples, keep)
    joints, positions = np.empty((kept, len(batch.joint_names))), np.empty((kept, 3))
    outside = np.empty(kept, dtype=bool) if hull is not None else None
    occupancy = VoxelOccupancy(voxel)
    occupancy_outside = VoxelOccupancy(voxel) if hull is not None else None
    accumulator = DexterityAccumulator(dexterity_voxel, grid.count) if grid is not None else None
    volume_at = {max(1, samples // 8), max(1, samples // 4), max(1, samples // 2), samples}
    dexterity_at = {max(1, samples // 4), max(1, samples // 2), samples} if grid is not None else set()
    convergence, dexterity_convergence, samples_outside, elapsed = [], [], 0, 0.0
    dexterity = cells = None
    for start, stop in chunk_spans(samples, chunk, sorted(volume_at | dexterity_at)):
        values = batch.sample(stop - start, rng)  # (n, n_f): the next rows of one uniform stream
        started = time.perf_counter()
        if grid is None:
            points = batch.positions(values)  # (n, 3)
        else:
            points, axes = batch.positions_and_axes(values, grid.axes)
            cells = grid.cells_from_axes(axes)  # (n,)
        elapsed += time.perf_counter() - started
        head = max(0, min(stop, kept) - start)  # rows of this chunk among the kept ones
        joints[start:start + head], positions[start:start + head] = values[:head], points[:head]
        occupancy.add(points)
        if hull is not None:
            mask = outside_hull(points, hull)
            outside[start:start + head] = mask[:head]
            samples_outside += int(np.count_nonzero(mask))
            points = points[mask]
            cells = cells[mask] if cells is not None else None
            occupancy_outside.add(points)
        if accumulator is not None:
            accumulator.add(points, cells)
        if stop in volume_at:
            convergence.append((stop, occupancy.volume))
        if stop in dexterity_at:
            dexterity = accumulator.map()
            dexterity_convergence.append((stop, dexterity.mean))
        if bar is not None:
            bar.update(stop - start)
    return FrameStream(joints, positions, outside, occupancy, occupancy_outside, samples_outside, dexterity,
                       convergence, dexterity_convergence, elapsed)


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
    keep_points: int | None = None,
    chunk: int | None = None,
) -> WorkspaceResult:
    """Sample each frame's joints uniformly, compute the poses in batch, measure volumes (and dexterity).

    The samples are streamed ``chunk`` at a time (`stream_frame`): memory does not grow
    with ``samples`` beyond the ``keep_points`` kept samples and the occupied voxels, so
    any sample count runs (10^9 samples of both xiang2019 arms take about half an hour).

    Args:
        robot: the model; points are in its vehicle frame (the world for a fixed base).
        frames: frame names; the common workspace is that of the first two.
        samples: joint samples per frame (an integer >= 1).
        seed: random seed (one generator for all frames, in order: all samples of the
            first frame, then of the second...). The result does not depend on ``chunk``.
        voxel: voxel edge for the volumes [m].
        progress: progress bar over the samples (None: only on a terminal).
        remove_hull: True to drop the samples inside the vehicle's solids (`hull_shapes`),
            or the solids to use; the volumes and dexterity outside the hull are added.
        dexterity: True (default `OrientationGrid`) or a grid to measure the dexterity per voxel.
        dexterity_voxel: voxel edge for the dexterity [m]; coarser than ``voxel`` because each
            voxel needs many samples to fill its orientation cells.
        keep_points: how many of the first samples of each frame keep their joint values and
            positions in the result (>= 0; default `POINTS_KEPT`).
        chunk: samples drawn and processed at once (>= 1; default ``CHUNK`` of this module).

    Returns:
        The WorkspaceResult.

    Raises:
        WorkspaceInputError: no frames, bad sample count, seed, voxel, keep_points or chunk, no hull geometry;
        FrameNotFound: an unknown frame.
    """
    frames = list(frames)
    if not frames:
        raise WorkspaceInputError("give at least one end-effector frame")
    samples = check_sample_count(samples)
    voxel, dexterity_voxel = check_voxel(voxel), check_voxel(dexterity_voxel, "dexterity voxel size")
    keep = POINTS_KEPT if keep_points is None else keep_points
    chunk = CHUNK if chunk is None else chunk
    for name, value, least in (("keep_points", keep, 0), ("chunk", chunk, 1)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < least:
            raise WorkspaceInputError(f"{name} must be an integer >= {least}, got {value!r}")
    hull = None
    if remove_hull is True:
        hull = hull_shapes(robot)
    elif remove_hull is not False and remove_hull is not None:
        hull = [remove_hull] if isinstance(remove_hull, HullShape) else list(remove_hull)
    grid = OrientationGrid() if dexterity is True else (dexterity or None)
    batches = [BatchKinematics(robot, frame) for frame in frames]  # unknown frames fail before any work
    rng = np.random.default_rng(check_seed(seed))
    streams: dict[str, FrameStream] = {}
    bar = tqdm(total=samples * len(frames), disable=(not progress) if progress is not None else None,
               desc="workspace", unit="sample", unit_scale=True, leave=False)
    try:
        for frame, batch in zip(frames, batches):
            bar.set_postfix_str(frame, refresh=False)
            streams[frame] = stream_frame(batch, samples, rng, chunk=int(chunk), keep=int(keep), voxel=voxel,
                                          hull=hull, grid=grid, dexterity_voxel=dexterity_voxel, bar=bar)
    finally:
        bar.close()
    shared = shared_outside = None
    if len(frames) >= 2:
        first, second = (streams[frame] for frame in frames[:2])
        shared = first.occupancy.common_volume(second.occupancy)
        if hull is not None:
            shared_outside = first.occupancy_outside.common_volume(second.occupancy_outside)
    removed, measured = hull is not None, grid is not None
    return WorkspaceResult(
        frames, samples, {f: s.joints for f, s in streams.items()}, {f: s.positions for f, s in streams.items()},
        {f: s.occupancy.volume for f, s in streams.items()}, shared, voxel,
        samples * len(frames) / max(sum(s.elapsed for s in streams.values()), 1e-12),
        {f: s.convergence for f, s in streams.items()}, hull=hull,
        outside_hull={f: s.outside for f, s in streams.items()} if removed else None,
        volume_outside_hull={f: s.occupancy_outside.volume for f, s in streams.items()} if removed else None,
        common_volume_outside_hull=shared_outside, orientation_grid=grid,
        dexterity={f: s.dexterity for f, s in streams.items()} if measured else None,
        dexterity_convergence={f: s.dexterity_convergence for f, s in streams.items()} if measured else None,
        samples_outside_hull={f: s.samples_outside for f, s in streams.items()} if removed else None)
