"""The files of a workspace run folder: points.npz, the workspace and dexterity figures, metrics.json."""

from __future__ import annotations

import shutil
from collections.abc import Sequence
from pathlib import Path

from ..io import outputs
from ..io.names import plain_file_name
from ..robot.robot import Robot
from ..workspace import CONVERGENCE_TOLERANCE, WorkspaceResult
from .plotting import workspace_figure


def write_workspace_outputs(robot: Robot, result: WorkspaceResult, frames: Sequence[str], figure_counts: Sequence[int],
                            threshold: float, folder: Path, tolerance: float = CONVERGENCE_TOLERANCE) -> list[str]:
    """Write points.npz, the workspace and dexterity figures and metrics.json of a workspace run into ``folder``.

    ``threshold`` is the dexterity of a dexterous voxel; ``tolerance`` the relative volume change over the last
    doubling of the samples below which a volume counts as converged (``volume_converged`` in metrics.json).

    Returns:
        The names of the figures written.
    """
    arrays = {}
    for frame in frames:
        arrays[f"q_{frame}"] = result.joints[frame]
        arrays[f"position_{frame}"] = result.positions[frame]
        if result.outside_hull is not None:
            arrays[f"outside_hull_{frame}"] = result.outside_hull[frame]
        if result.dexterity is not None:
            arrays[f"dexterity_centre_{frame}"] = result.dexterity[frame].centres
            arrays[f"dexterity_{frame}"] = result.dexterity[frame].dexterity
            arrays[f"dexterity_samples_{frame}"] = result.dexterity[frame].samples
    outputs.write_npz(folder / "points.npz", **arrays)
    outlines = [shape.outline() for shape in result.hull] if result.hull is not None else None
    hull_note = ", hull removed" if result.hull is not None else ""
    stored = min(result.stored(frame) for frame in frames)
    written, drawn = [], {}
    for name, count in [(f"workspace_{n}.png", n) for n in figure_counts] + [("workspace.png", result.samples)]:
        if count in drawn:  # the same cloud: copy the image instead of drawing it again
            shutil.copyfile(folder / drawn[count], folder / name)
        else:
            shown = min(count, stored)  # beyond the kept samples: the first ones, a uniform subsample
            label = (f"{count} samples per arm" if shown == count
                     else f"{count} samples per arm, the first {shown} drawn")
            workspace_figure({frame: result.cloud(frame, shown) for frame in frames}, folder / name, outlines=outlines,
                             title=f"{robot.name}: reachable workspace (vehicle frame), {label}{hull_note}")
            drawn[count] = name
        written.append(name)
    for frame, dexterity in (result.dexterity or {}).items():
        grid = result.orientation_grid
        name = f"dexterity_{plain_file_name(frame, 'frame')}.png"  # "rexrov/ee" is one file, not a folder
        workspace_figure({frame: dexterity.centres}, folder / name, values={frame: dexterity.dexterity},
                         value_label=f"dexterity (fraction of {grid.count} orientation cells)", outlines=outlines,
                         marker_size=16.0,
                         title=f"{robot.name} {frame}: dexterity per {dexterity.voxel} m voxel, "
                               f"{result.samples} samples{hull_note} (max along the line of sight)")
        written.append(name)
    metrics = {"model": robot.name, **result.metrics(threshold, tolerance), "figures": written}
    outputs.write_json(folder / "metrics.json", metrics)
    return written
