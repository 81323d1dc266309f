"""Figures of a scenario run: desired motion, vehicle, joints, errors, path, velocities.

Figures are built with matplotlib's object interface (``matplotlib.figure.Figure``), not pyplot, so
writing them needs no display and leaves the caller's backend (e.g. a notebook's inline one) alone.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.colors import to_rgba
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import MaxNLocator

from ..errors import UVMSError
from ..io import outputs
from ..robot.conventions import AXIS_NAMES
from ..sim.result import SimulationResult
from ..trajectory.table import twists_at
from .labels import arm_joint_labels, legend_below
from .paths import path_figure

#: [m, rad] Errors below this are at the rounding level of double precision over a run: errors.png draws them on
#: one floor line so labelled, not as a band of noise.
ROUNDING_LEVEL = 1e-12


def stacked(t: np.ndarray, series: np.ndarray, labels, title: str, limits=None, dashed=None):
    """One subplot per column of ``series`` against t; optional limit lines and dashed references.

    The layout is constrained: the title gets its own room above the first panel, however many panels."""
    count = series.shape[1]
    figure = Figure(figsize=(7, 1.9 * count + 0.6), layout="constrained")
    axes = figure.subplots(count, 1, sharex=True, squeeze=False)
    for index, axis in enumerate(axes[:, 0]):
        axis.plot(t, series[:, index], color="C0", label="actual" if dashed is not None else None)
        if dashed is not None:
            axis.plot(t, dashed[:, index], "--", color="C1", label="desired")
        if limits is not None and np.isfinite(limits[0][index]):
            for bound in (limits[0][index], limits[1][index]):
                axis.axhline(bound, color="0.5", linestyle=":", linewidth=1)
        axis.set_ylabel(labels[index])
        axis.grid(True, alpha=0.3)
    if dashed is not None:  # above the first panel, clear of the curves
        axes[0, 0].legend(loc="lower right", bbox_to_anchor=(1.0, 1.0), ncol=2, fontsize=8)
    axes[-1, 0].set_xlabel("t [s]")
    figure.suptitle(title)
    return figure


def motion_axes(axes: Sequence[str]) -> list[str]:
    """The controlled axes (of x, y, z, roll, pitch, yaw) in that order; all six when none are named."""
    named = [axis for axis in AXIS_NAMES if axis in axes]
    return named or list(AXIS_NAMES)


def desired_motion_figure(result: SimulationResult, trajectory, title: str = "") -> Figure:
    """Desired speed and every controlled axis of the task against time (x_d, y_d, z_d [m], roll_d ... [rad])."""
    t = result.t
    speed = np.linalg.norm(twists_at(trajectory, t)[:, :3], axis=1)  # the path's samples in one call where it can
    columns, labels = [speed], ["speed [m/s]"]
    for axis in motion_axes(result.axes or result.robot.base.task_axes):
        index = AXIS_NAMES.index(axis)
        columns.append(result.desired_position[:, index] if index < 3 else result.desired_rpy[:, index - 3])
        labels.append(f"{axis}_d [{'m' if index < 3 else 'rad'}]")
    return stacked(t, np.column_stack(columns), labels, f"{title}: desired end-effector motion")


def error_figure(result: SimulationResult, title: str = "") -> Figure:
    """Position [m] and orientation [rad] errors on a log axis; values below :data:`ROUNDING_LEVEL` (exact zeros
    included) lie on a floor line labelled "rounding level", and a series that never rises above it says so. The
    legend sits below the axes, clear of the curves."""
    figure = Figure(figsize=(7, 3.8), layout="constrained")
    axis = figure.subplots()
    series = [(result.position_error, "position error [m]")]
    if np.any(result.orientation_error > 0):
        series.append((result.orientation_error, "orientation error [rad]"))
    for values, label in series:
        below = not np.any(values > ROUNDING_LEVEL)
        axis.semilogy(result.t, np.maximum(values, ROUNDING_LEVEL),
                      label=f"{label}: at rounding level throughout" if below else label)
    axis.axhline(ROUNDING_LEVEL, color="0.4", linestyle=":", linewidth=1.2,
                 label=f"rounding level ({ROUNDING_LEVEL:g})")
    axis.set_ylim(bottom=ROUNDING_LEVEL / 3)
    axis.set_xlabel("t [s]")
    axis.set_ylabel("error [m] or [rad]" if len(series) == 2 else "position error [m]")
    axis.grid(True, which="both", alpha=0.3)
    legend_below(figure, list(zip(*axis.get_legend_handles_labels())), columns=2)
    axis.set_title(f"{title}: tracking error")
    return figure


def run_figures(result: SimulationResult, trajectory, title: str = "") -> dict[str, Figure]:
    """The standard figures of a run, by file name (what :func:`scenario_figures` writes).

    ``desired_motion.png`` and ``path.png`` follow the task's axes (``result.axes``): every controlled axis
    against time, and the path in 3-D or in the task's plane (:func:`uvms.viz.paths.path_figure`).
    ``vehicle_velocity.png`` shows v's vehicle entries as they are, the body twist in FLU axes.
    """
    robot, t = result.robot, result.t
    figures = {"desired_motion.png": desired_motion_figure(result, trajectory, title)}
    if robot.base_type != "fixed":
        figures["vehicle.png"] = stacked(t, result.vehicle_pose(), robot.base.pose_labels,
                                         f"{title}: vehicle pose")
        figures["vehicle_velocity.png"] = stacked(t, result.v[:, : robot.n_vehicle], list(robot.base.velocity_labels),
                                                  f"{title}: vehicle velocities in its body axes (FLU)")
    if robot.n_arm:  # a vehicle without an arm has no joints to draw
        figures["joints.png"] = stacked(t, result.arm(), arm_joint_labels(robot),
                                        f"{title}: arm joints (dotted: limits)", limits=robot.arm_limits)
    figures["errors.png"] = error_figure(result, title)
    figures["path.png"] = path_figure(result, title)
    return figures


def scenario_figures(result: SimulationResult, trajectory, folder: str | os.PathLike, title: str = "") -> list[Path]:
    """Write the standard figures of a run (:func:`run_figures`) into ``folder``; returns their paths."""
    written = []
    for name, figure in run_figures(result, trajectory, title).items():
        outputs.save_figure(figure, Path(folder) / name)
        written.append(Path(folder) / name)
    return written


#: Cloud colours in frame order: xiang2019 draws the left arm blue and the right arm red.
CLOUD_COLOURS = ("tab:blue", "tab:red", "tab:green", "tab:orange")
#: Ticks on each axis of the 3-D cloud (more crowd its slanted labels).
CLOUD_TICKS = 4


def cloud_alpha(total: int) -> float:
    """Opacity of the points of a cloud of ``total`` points: lower for denser clouds, so that where two frames'
    clouds overlap both colours show (mixed), and a dense cloud does not turn into a flat blot."""
    return float(np.clip(np.sqrt(20_000.0 / max(total, 1)), 0.2, 0.6))


def workspace_figure(positions: dict[str, np.ndarray], path: str | os.PathLike, title: str = "",
                     max_points: int | None = 100_000, values: dict[str, np.ndarray] | None = None,
                     value_label: str = "", outlines=None, marker_size: float | None = None) -> Path:
    """A 3-D cloud and its x-z, x-y, y-z projections (xiang2019 Fig. 4), one colour per frame.

    The frames' points are drawn as one collection in a shuffled order, translucent (:func:`cloud_alpha`): no
    frame's cloud hides another's by being drawn after it; the legend sits below the panels.

    Args:
        positions: per frame, points (N, 3) [m]; frames are drawn blue, red, green, orange in order.
        path: the PNG to write.
        title: figure title.
        max_points: at most this many points per frame are drawn (evenly thinned); None: all.
        values: per frame, one number per point (N,): points are coloured by it (viridis, one
            colour bar) instead of by frame, highest drawn last so that each projection shows
            the largest value along the line of sight (e.g. dexterity per voxel centre).
        value_label: label of the colour bar.
        outlines: polylines (K, 3) [m] drawn in grey in every panel (e.g. the vehicle hull);
            NaN rows separate pieces.
        marker_size: scatter marker area [pt^2]; default: smaller for denser clouds.

    Returns:
        The path written.
    """
    figure = Figure(figsize=(11, 9.4), layout="constrained")
    figure.get_layout_engine().set(wspace=0.1)  # the 3-D z label sticks out of its Axes: clear of the next panel
    cloud = figure.add_subplot(2, 2, 1, projection="3d")
    planes = [figure.add_subplot(2, 2, k) for k in (2, 3, 4)]
    pairs = ((0, 2), (0, 1), (1, 2))
    shown, colours = [], []
    for (frame, points), frame_colour in zip(positions.items(), CLOUD_COLOURS):
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        step = 1 if max_points is None else max(1, -(-len(points) // max_points))  # no more points than pixels
        shown.append(points[::step])
        colours.append(np.asarray(values[frame], dtype=float)[::step] if values is not None
                       else np.broadcast_to(to_rgba(frame_colour), (len(shown[-1]), 4)))
    points, colour = np.concatenate(shown or [np.empty((0, 3))]), np.concatenate(colours or [np.empty((0, 4))])
    total = len(points)
    size = marker_size if marker_size is not None else float(np.clip(20_000.0 / max(total, 1), 1.5, 12.0))
    if values is not None:  # the highest value last: each projection shows the largest along the line of sight
        order = np.argsort(colour, kind="stable")
        style = {"cmap": "viridis", "vmin": 0.0, "vmax": float(np.max(colour, initial=0.0)) or 1.0}
    else:  # the frames interleaved: none drawn over another as a whole
        order = np.random.default_rng(0).permutation(total)
        style = {"alpha": cloud_alpha(total), "linewidths": 0}  # no edges: the marker's area is its size
    points, colour = points[order], colour[order]
    mappable = cloud.scatter(points[:, 0], points[:, 1], points[:, 2], s=size, c=colour, depthshade=False, **style)
    for axis, (a, b) in zip(planes, pairs):
        axis.scatter(points[:, a], points[:, b], s=size, c=colour, **style)
    for line in outlines or ():
        line = np.asarray(line, dtype=float)
        cloud.plot(line[:, 0], line[:, 1], line[:, 2], color="0.4", linewidth=0.8)
        for axis, (a, b) in zip(planes, pairs):
            axis.plot(line[:, a], line[:, b], color="0.4", linewidth=0.8)
    if total:
        span = np.ptp(points, axis=0)
        cloud.set_box_aspect(np.maximum(span, 0.05 * max(float(span.max()), 1e-9)))  # true proportions
    for coordinate, name in zip((cloud.xaxis, cloud.yaxis, cloud.zaxis), "xyz"):
        coordinate.set_major_locator(MaxNLocator(CLOUD_TICKS))  # slanted labels clear of each other
        coordinate.set_label_text(f"{name} [m]")
    if values is None:
        legend_below(figure, [(Line2D([], [], marker="o", linestyle="none", color=frame_colour), frame)
                              for frame, frame_colour in zip(positions, CLOUD_COLOURS)], columns=len(positions))
    elif total:
        figure.colorbar(mappable, ax=[cloud, *planes], shrink=0.6, label=value_label)
    for axis, (a, b) in zip(planes, ("xz", "xy", "yz")):
        axis.set_xlabel(f"{a} [m]")
        axis.set_ylabel(f"{b} [m]")
        axis.set_aspect("equal", adjustable="datalim")
        axis.grid(True, alpha=0.3)
        axis.set_title(f"{a}-o-{b} projection")
    figure.suptitle(title)
    outputs.save_figure(figure, path)
    return Path(path)


#: Rows of :func:`joint_trajectory_figure`: (quantity, unit suffix) and how a joint of each unit is drawn.
TRAJECTORY_ROWS = (("position", ""), ("velocity", "/s"), ("acceleration", "/s²"))
DRAWN_UNITS = {"rad": ("deg", np.rad2deg), "m": ("m", np.asarray)}


def joint_trajectory_figure(samples, path: str | os.PathLike | None = None, title: str = "",
                            names: list[str] | None = None, marks=None, units: Sequence[str] | None = None) -> Figure:
    """Position, velocity and acceleration of every joint (xiang2019 Figs. 5-6): revolute joints in degrees,
    prismatic ones in metres.

    Args:
        samples: a ``JointSamples`` (t (N,), q, qd, qdd (N, n) in rad or m).
        path: where to save the PNG (atomically); None to only return the figure.
        names: joint names for the column titles; marks: times [s] drawn as dotted lines (via points).
        units: "rad" or "m" per joint (:func:`uvms.viz.labels.joint_unit`); default: every joint in rad.
    """
    count = samples.q.shape[1]
    units = list(units) if units is not None else ["rad"] * count
    if len(units) != count or not set(units) <= set(DRAWN_UNITS):
        raise UVMSError(f"units must hold 'rad' or 'm' for each of the {count} joints, got {units!r}")
    figure = Figure(figsize=(3.2 * count, 7), layout="constrained")
    axes = figure.subplots(3, count, sharex=True, squeeze=False)
    for row, (values, (quantity, per)) in enumerate(zip((samples.q, samples.qd, samples.qdd), TRAJECTORY_ROWS)):
        for joint in range(count):
            axis = axes[row, joint]
            unit, convert = DRAWN_UNITS[units[joint]]
            axis.plot(samples.t, convert(values[:, joint]), color=f"C{joint}")
            for mark in marks if marks is not None else ():
                axis.axvline(mark, color="0.6", linestyle=":", linewidth=1)
            axis.grid(True, alpha=0.3)
            if joint == 0 or units[joint] != units[joint - 1]:  # a label wherever the unit changes
                axis.set_ylabel(f"{quantity} [{unit}{per}]")
            if row == 0:
                axis.set_title(names[joint] if names else f"joint {joint + 1}")
            if row == 2:
                axis.set_xlabel("t [s]")
    figure.suptitle(title)
    if path is not None:
        outputs.save_figure(figure, path)
    return figure


def sequence_figures(result: SimulationResult, plan, folder: str | os.PathLike, title: str = "",
                     animation: str = "", progress: bool | None = None) -> list[Path]:
    """Figures of a phase sequence: every frame against its target, configuration snapshots, an animation.

    Args:
        result: the run; plan: its ``uvms.control.sequence.PhasePlan``; folder: output folder.
        animation: file name of the animation (``.gif`` or ``.mp4``), "" for none.
        progress: progress bar of the animation (None: on a terminal only).
    """
    from ..control.sequence import frame_positions
    from .drawing import animate, snapshot_figure  # 3-D drawing only when asked for

    folder, robot, t = Path(folder), result.robot, result.t
    positions = frame_positions(robot, plan.frames, result.q)
    actual = np.column_stack([positions[frame] for frame in plan.frames])
    desired = np.column_stack([[plan(time_).positions[frame][0] for time_ in t] for frame in plan.frames])
    labels = [f"{frame} {axis} [m]" for frame in plan.frames for axis in "xyz"]
    figure = stacked(t, actual, labels, f"{title}: frames (dashed: targets)", dashed=desired)
    for axis in figure.axes:
        for boundary in plan.times[1:-1]:
            axis.axvline(boundary, color="0.6", linestyle=":", linewidth=1)
    outputs.save_figure(figure, folder / "frames.png")
    rows = [int(np.argmin(np.abs(t - boundary))) for boundary in plan.times]
    titles = [f"({chr(97 + k)}) t = {t[row]:.1f} s" + (f", after {plan.phases[k - 1].name}" if k else ", start")
              for k, row in enumerate(rows)]
    view = (15.0, -25.0)  # from ahead and to the side: the arms move mostly across and down
    snapshot_figure(robot, result.q[rows], titles=titles, path=folder / "snapshots.png", frames=plan.frames, view=view)
    written = [folder / "frames.png", folder / "snapshots.png"]
    if animation:
        step = max(1, int(round(0.2 / (t[1] - t[0]))))  # 5 frames per second of motion
        written.append(animate(robot, result.q[::step], folder / animation, fps=5, times=t[::step],
                               trail_frame=plan.frames[0], title=title, frames=plan.frames, view=view,
                               progress=progress))
    return written


def gjm_tracking_figure(result, title: str = "", path: str | os.PathLike | None = None) -> Figure:
    """End-effector velocity (above) and position (below) against the reference (amundsen2018 Figs. 5 and 7).

    Solid: measured in the plant; dashed: the reference v_d and its integral p_d (eq. 9-11). Positions
    are drawn relative to the start; world ENU axes (x forward, y left, z up).

    Args:
        result: a :class:`uvms.sim.result.SimulationResult` of a tracking-controlled plant (its ``tracking``).
        title: figure title; path: where to save the PNG (atomically), None to only return it.
    """
    t = result.t
    figure = Figure(figsize=(8.8, 6.5), layout="constrained")
    velocity_axis, position_axis = figure.subplots(2, 1, sharex=True)
    tracking = result.tracking
    start = tracking.desired_position[0]
    for index, name in enumerate("xyz"):
        colour = f"C{index}"
        velocity_axis.plot(t, tracking.ee_velocity[:, index], color=colour, label=f"v_{name}")
        velocity_axis.plot(t, tracking.desired_velocity[:, index], "--", color=colour, label=f"v_{name},d")
        position_axis.plot(t, tracking.ee_position[:, index] - start[index], color=colour,
                           label=f"{name} - {name}(0)")
        position_axis.plot(t, tracking.desired_position[:, index] - start[index], "--", color=colour,
                           label=f"{name}_d - {name}(0)")
    velocity_axis.set_ylabel("end-effector velocity [m/s]")
    position_axis.set_ylabel("end-effector position [m]")
    position_axis.set_xlabel("t [s]")
    for axis in (velocity_axis, position_axis):
        axis.grid(True, alpha=0.3)
        axis.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5))  # beside the axes, off the data
    velocity_axis.set_title(f"{title}: solid measured, dashed reference; final |p_d - p| = "
                            f"{1000 * result.final_position_error:.3g} mm", fontsize=9)
    if path is not None:
        outputs.save_figure(figure, path)
    return figure


def snapshot_rows(t: np.ndarray, count: int = 4) -> list[int]:
    """Rows of ``t`` nearest to ``count`` evenly spaced times at the middles of equal slices (8 s -> 1, 3, 5, 7 s)."""
    duration = float(t[-1] - t[0])
    return [int(np.argmin(np.abs(t - (t[0] + duration * (2 * k + 1) / (2 * count))))) for k in range(count)]


def gjm_figures(result, folder: str | os.PathLike, title: str = "", snapshots: int = 4) -> list[Path]:
    """Figures of a GJM-controlled plant run: tracking (Figs. 5/7), joint rates, configuration snapshots (Fig. 6).

    Writes ``ee_tracking.png``, ``joint_rates.png`` (measured solid, command dashed) and
    ``snapshots.png`` (the configuration at ``snapshots`` evenly spaced times, 1, 3, 5, 7 s for 8 s).

    Args:
        result: a :class:`uvms.sim.result.SimulationResult` of a tracking-controlled plant (its ``plant`` and
            ``tracking`` series); folder: output folder; title: figure titles.

    Returns:
        The paths written.
    """
    from .drawing import snapshot_figure  # 3-D drawing only when asked for

    folder = Path(folder)
    robot, t = result.robot, result.t
    gjm_tracking_figure(result, title, folder / "ee_tracking.png")
    figure = stacked(t, result.joint_rates(), arm_joint_labels(robot, per_second=True),
                     f"{title}: joint rates (solid) and commands (dashed)",
                     dashed=result.plant.command)
    outputs.save_figure(figure, folder / "joint_rates.png")
    rows = snapshot_rows(t, snapshots)
    titles = [f"({chr(97 + k)}) t = {t[row]:.1f} s" for k, row in enumerate(rows)]
    planar = robot.base_type == "planar"
    figure = snapshot_figure(robot, result.q[rows], titles=titles, frames=[result.tracking.frame],
                             plane="xy" if planar else None)
    figure.subplots_adjust(top=0.84)  # room for the suptitle above the panel titles
    figure.suptitle(f"{title}: configurations", y=0.99)
    outputs.save_figure(figure, folder / "snapshots.png")
    return [folder / "ee_tracking.png", folder / "joint_rates.png", folder / "snapshots.png"]
