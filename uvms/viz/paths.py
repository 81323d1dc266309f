"""``path.png``: the end effector, its desired path and the vehicle in the task's axes, read at a glance.

Each path the robot travels shows where it starts (circle), where it ends (square) and which way it goes (arrows
along it). The desired path lies underneath as a wide light band and the travelled paths on top as thin solid lines,
so that the end effector stays visible inside the band where it tracks it exactly. The legend sits below the axes,
clear of the data. A 3-D path keeps equal scales on x, y and z (the box is shaped by the data's ranges).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import MaxNLocator

from ..sim.result import SimulationResult
from .labels import figure_title, legend_below

#: Direction arrows along each travelled path.
ARROWS = 4
#: Style of the desired path: a wide light band under the travelled paths (drawn first, lowest zorder).
DESIRED_STYLE = {"color": "C1", "linewidth": 7.0, "alpha": 0.35, "solid_capstyle": "round", "zorder": 1}
#: [in] Room at the bottom of a 3-D path figure for the legend's two rows (a 2-D one is laid out by matplotlib).
LEGEND_ROOM = 0.75
#: Style of a travelled path: a thin solid line above the desired band.
TRAVELLED_STYLE = {"linewidth": 1.4, "zorder": 3}
#: The smallest side of a 3-D path's box, as a fraction of its largest (a flat path keeps a readable box; the
#: scale stays equal on every axis because the limits grow with the box).
MIN_BOX_SIDE = 0.25


def path_coordinates(axes: Sequence[str], desired: np.ndarray) -> tuple[int, ...]:
    """Which of x, y, z (indices) a path figure shows: the task's position axes when it controls two or three,
    else the controlled one and those along which the desired path (N, 3) [m] moves most (x, y if it does not).

    Returns:
        Three indices (a 3-D path) or two in increasing order (a plane).
    """
    controlled = [index for index, name in enumerate("xyz") if name in axes]
    if len(controlled) >= 2:
        return tuple(controlled)
    spans = np.ptp(desired, axis=0) if len(desired) else np.zeros(3)
    ranked = [index for index in np.argsort(-spans, kind="stable") if spans[index] > 0 and index not in controlled]
    chosen = controlled + ranked + [index for index in (0, 1, 2) if index not in controlled and index not in ranked]
    return tuple(sorted(chosen[:2]))


def arrow_segments(points: np.ndarray, count: int = ARROWS) -> list[tuple[np.ndarray, np.ndarray]]:
    """(tail, head) pairs along a path (N, d): ``count`` arrows at the middles of equal lengths of it, each a short
    step (0.2 % of the path's length, at least one row) in the direction of travel: the arrow's head is drawn in
    points, so its shaft stays invisible. None for a path that does not move."""
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])  # (N,) length so far
    if len(points) < 2 or arc[-1] <= 0:
        return []
    segments = []
    for fraction in (np.arange(count) + 0.5) / count:
        tail = min(int(np.searchsorted(arc, fraction * arc[-1])), len(points) - 2)
        head = min(int(np.searchsorted(arc, arc[tail] + 0.002 * arc[-1])), len(points) - 1)
        segments.append((points[tail], points[max(head, tail + 1)]))
    return segments


def draw_travel(axis, points: np.ndarray, colour: str, size: float) -> None:
    """Start (circle), end (square) and direction arrows of a path (N, d) in shown coordinates; ``size``: the
    arrows' length on a 3-D axis [m], and the shortest path that gets arrows."""
    axis.plot(*points[0], "o", color=colour, markersize=7, zorder=4)
    axis.plot(*points[-1], "s", color=colour, markeredgecolor="k", markersize=7, zorder=4)
    length = float(np.sum(np.linalg.norm(np.diff(points, axis=0), axis=1)))
    if length < size:  # a path that (nearly) stays put: its start and end say it all
        return
    for tail, head in arrow_segments(points):
        if points.shape[1] == 3:
            axis.quiver(*tail, *(head - tail), length=size, normalize=True, color=colour, arrow_length_ratio=0.5)
        else:
            axis.annotate("", xy=head, xytext=tail, zorder=4,
                          arrowprops={"arrowstyle": "-|>", "color": colour, "lw": 1.5, "mutation_scale": 16,
                                      "shrinkA": 0, "shrinkB": 0})


def equal_box(axis, points: np.ndarray) -> np.ndarray:
    """Limits of a 3-D axis around ``points`` (N, 3) [m] with one scale on x, y and z: the box is shaped by the
    ranges, each side at least :data:`MIN_BOX_SIDE` of the largest. Returns the ranges (3,) [m]."""
    low, high = points.min(axis=0), points.max(axis=0)
    span = high - low
    ranges = np.maximum(span, MIN_BOX_SIDE * max(float(span.max()), 1e-3)) * 1.1
    for setter, middle, extent in zip((axis.set_xlim, axis.set_ylim, axis.set_zlim), (low + high) / 2, ranges):
        setter(middle - extent / 2, middle + extent / 2)
    axis.set_box_aspect(ranges, zoom=0.85)  # zoom: room for the tick and axis labels inside the figure
    for coordinate, extent in zip((axis.xaxis, axis.yaxis, axis.zaxis), ranges / ranges.max()):
        coordinate.set_major_locator(MaxNLocator(max(2, int(round(6 * extent)))))  # no crowded ticks
    return ranges


def path_figure(result: SimulationResult, title: str = "") -> Figure:
    """End effector, its desired path and the vehicle in the task's own axes: 3-D when the task controls x, y
    and z, else the plane of its two position axes (or of the two along which the path moves)."""
    robot = result.robot
    shown = list(path_coordinates(result.axes or robot.base.task_axes, result.desired_position))
    names = ["xyz"[index] for index in shown]
    three_d = len(shown) == 3
    figure = Figure(figsize=(7, 7.2) if three_d else (6, 6.6), layout=None if three_d else "constrained")
    axis = figure.add_subplot(projection="3d") if three_d else figure.subplots()
    travelled = [(result.ee_position[:, shown], "C0", "end effector")]
    if robot.base_type != "fixed":
        vehicle = np.array([robot.base_pose(q, check=False).translation for q in result.q])  # (N, 3) [m] world
        travelled.append((vehicle[:, shown], "C2", "vehicle"))
    desired = result.desired_position[:, shown]
    everything = np.vstack([desired, *(points for points, _, _ in travelled)])
    size = 0.06 * float(np.ptp(everything, axis=0).max())
    axis.plot(*desired.T, label="desired (light band)", **DESIRED_STYLE)
    for points, colour, label in travelled:
        axis.plot(*points.T, color=colour, label=label, **TRAVELLED_STYLE)
        draw_travel(axis, points, colour, size)
    entries = list(zip(*axis.get_legend_handles_labels()))
    entries += [(Line2D([], [], marker="o", color="0.4", linestyle="none"), "start"),
                (Line2D([], [], marker="s", color="0.4", markeredgecolor="k", linestyle="none"), "end"),
                (Line2D([], [], marker=r"$\rightarrow$", color="0.4", markersize=12, linestyle="none"),
                 "direction of travel")]
    legend_below(figure, entries, columns=3)
    if three_d:
        equal_box(axis, everything)
        axis.tick_params(pad=4)  # minus signs clear of the tick marks
        axis.set_zlabel("z [m]", labelpad=24)  # clear of the tick labels
        plane = "3-D (x, y, z; equal scales)"
    else:
        axis.set_aspect("equal", adjustable="datalim")
        axis.grid(True, alpha=0.3)
        plane = f"the {names[0]}-{names[1]} plane"
    pad = {"labelpad": 14} if three_d else {}
    axis.set_xlabel(f"{names[0]} [m]", **pad)
    axis.set_ylabel(f"{names[1]} [m]", **pad)
    text = figure_title(f"{title}: paths in {plane}", figure.get_figwidth())
    figure.suptitle(text)
    if three_d:  # the constrained layout does not fit 3-D axes: room for the title's lines by hand
        figure.subplots_adjust(left=0.0, right=0.94, bottom=LEGEND_ROOM / figure.get_figheight(),
                               top=0.97 - 0.045 * (text.count("\n") + 1))
    return figure
