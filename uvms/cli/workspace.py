"""``uvms workspace``: the Monte Carlo reachable workspace of a model's end effectors from the command line."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..errors import UVMSError
from ..io.names import default_output_folder
from .info import command_model
from .run import say_replaced, watch_job
from .terminal import say


def parse_figure_counts(text: str | None, samples: int) -> list[int]:
    """``"10000,50000,100000"`` -> [10000, 50000, 100000], each in [1, samples]."""
    if not text:
        return []
    try:
        counts = [int(item) for item in text.split(",") if item.strip()]
    except ValueError:
        counts = []
    if not counts or any(not 1 <= count <= samples for count in counts):
        raise UVMSError(f"--figures expects comma-separated sample counts in [1, {samples}] (-n), got {text!r}")
    return counts


def command_workspace(options: argparse.Namespace) -> int:
    """``uvms workspace MODEL --ee FRAME ... -n N``: Monte Carlo workspace, volumes, dexterity, points and figures.

    The samples are streamed (memory bounded for any N); points.npz and the scatter figures hold the first
    `uvms.workspace.POINTS_KEPT` samples per frame, and metrics.json says how many were stored (points_stored)
    of how many sampled (points_sampled).
    """
    from ..io import outputs
    from ..viz.reports import write_workspace_outputs
    from ..workspace import OrientationGrid, monte_carlo, parse_sample_count
    from ..workspace.montecarlo import check_seed

    samples = parse_sample_count(options.samples)
    check_seed(options.seed)
    if not 0.0 < options.convergence_tolerance < 1.0:
        raise UVMSError(f"--convergence-tolerance must be in (0, 1) (0.01: 1 %), got {options.convergence_tolerance}")
    robot = command_model(options)
    frames = robot.ee_frames  # --ee, else the model's rule
    figure_counts = parse_figure_counts(options.figures, samples)
    if not 0.0 <= options.dexterous_threshold <= 1.0:
        raise UVMSError(f"--dexterous-threshold must be in [0, 1], got {options.dexterous_threshold}")
    grid = OrientationGrid(options.directions, options.roll_bins, options.approach) if options.dexterity else False
    out = Path(options.out or default_output_folder("workspace", robot.name))
    if options.watch:
        return watch_job(options, out, model=options.model)
    from ..scenario.watch import WatchedFiles

    model_files = WatchedFiles.of(model=options.model)  # the model, its includes and their folders: never deleted
    inputs = model_files.files | model_files.folders
    replacing = outputs.holds_run(out)
    with outputs.run_folder(out, inputs=inputs) as folder:  # taken first: a second writer is refused at once
        result = monte_carlo(robot, frames, samples, seed=options.seed, voxel=options.voxel,
                             progress=False if options.quiet else None, remove_hull=options.remove_hull,
                             dexterity=grid, dexterity_voxel=options.dexterity_voxel)
        written = write_workspace_outputs(robot, result, frames, figure_counts, options.dexterous_threshold, folder,
                                          tolerance=options.convergence_tolerance)
    for frame in frames:
        line = f"{frame:<12} volume {result.volume[frame]:.4f} m^3 ({result.voxel} m voxels)"
        if result.volume_outside_hull is not None:
            line += f", outside the hull {result.volume_outside_hull[frame]:.4f} m^3"
        say(line, sys.stdout)
    if result.common_volume is not None:
        line = f"{'common':<12} volume {result.common_volume:.4f} m^3"
        if result.common_volume_outside_hull is not None:
            line += f", outside the hull {result.common_volume_outside_hull:.4f} m^3"
        say(line, sys.stdout)
    convergence = result.volume_converged(options.convergence_tolerance)
    for frame, verdict in convergence.items():
        say(verdict.status(frame), sys.stdout)
    for frame, dexterity in (result.dexterity or {}).items():
        summary = dexterity.summary(options.dexterous_threshold)
        say(f"{frame:<12} dexterity mean {summary['mean']:.4f}, max {summary['max']:.4f} "
            f"({result.orientation_grid.count} orientation cells, {dexterity.voxel} m voxels, "
            f"median {summary['median_samples_per_voxel']:.0f} samples/voxel); "
            f"dexterous (>= {options.dexterous_threshold}) {summary['dexterous_volume']:.4f} m^3", sys.stdout)
    stored = min(result.stored(frame) for frame in frames)
    if stored < result.samples:
        say(f"points.npz and the scatter figures keep the first {stored} of the {result.samples} samples per frame "
            f"(volumes and dexterity use all)", sys.stdout)
    say(f"{result.samples_per_second:,.0f} samples/s; outputs in {out}/ (metrics.json, points.npz, "
        f"{', '.join(written)})", sys.stdout)
    say_replaced(replacing, out)
    for frame, verdict in convergence.items():  # said on the terminal, not only in metrics.json
        if verdict.warning(frame):
            say(f"uvms: warning: {verdict.warning(frame)}")
    return 0
