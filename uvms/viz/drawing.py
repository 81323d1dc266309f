"""Headless stick pictures of a configuration: kinematic tree, joints, end-effector triads, vehicle box.

Everything is drawn with matplotlib's object interface (``matplotlib.figure.Figure``), never pyplot,
so no display is needed and a notebook keeps its backend. The tree is one segment per arm joint (parent joint
origin -> joint origin, the universe being the world origin), a dot per joint, a segment and an RGB triad (x red,
y green, z blue) per end-effector frame, and the vehicle as the 12 edges of the box of its link's ``<visual>``
(else ``<collision>``), or a triad when it has none; the triads' length follows the robot's size
(:func:`configuration_geometry`). Meshes come with an overlay (:class:`~uvms.viz.collision_drawing.CollisionOverlay`:
the visual meshes of ``uvms view --headless``, or the collision shapes).
"""

from __future__ import annotations

import itertools
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin
from matplotlib import animation
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import MaxNLocator

from ..errors import ConfigurationError, UVMSError
from ..io import outputs
from ..io.progress import tqdm
from ..robot import configuration as states
from ..robot.configuration import Configuration
from ..robot.robot import Robot
from .collision_drawing import CollisionOverlay
from .labels import legend_below
from .visual_shapes import body_size, vehicle_box

PLANES = {"xy": (0, 1), "xz": (0, 2), "yz": (1, 2)}
WRITERS = {".gif": animation.PillowWriter, ".mp4": animation.FFMpegWriter}
TRIAD_COLOURS = ("tab:red", "tab:green", "tab:blue")
#: [in] Room a snapshot figure keeps above and below its panels: tight_layout misses a 3-D panel's title and labels.
LABEL_MARGIN = 0.3
#: Ticks on each axis of a 3-D panel (more crowd its slanted labels).
TICKS_3D = 4
CORNER_SIGNS = np.array(list(itertools.product((-1.0, 1.0), repeat=3)))  # (8, 3), corner k = signs[k] * size / 2
BOX_EDGES = [(i, j) for i, j in itertools.combinations(range(8), 2)
             if np.count_nonzero(CORNER_SIGNS[i] != CORNER_SIGNS[j]) == 1]  # 12 pairs


@dataclass
class ConfigurationGeometry:
    """World positions [m] of what a configuration drawing shows (no matplotlib objects).

    Attributes:
        joint_names: every joint but the universe, in model order (n,).
        joint_positions: joint origins ``data.oMi[j].translation`` (n, 3).
        segments: one per arm joint, parent joint origin -> joint origin (n_arm_joints, 2, 3).
        ee_segments: parent joint origin -> end-effector frame origin (n_frames, 2, 3).
        triads: per frame, its x, y, z axes as segments (n_triads, 3, 2, 3); the vehicle's is last
            when it has no box.
        box_corners: vehicle box corners, corner k at ``CORNER_SIGNS[k] * size / 2`` (8, 3), or None.
        triad_length: length of the end-effector triad axes [m].
    """

    joint_names: list[str]
    joint_positions: np.ndarray
    segments: np.ndarray
    ee_segments: np.ndarray
    triads: np.ndarray
    box_corners: np.ndarray | None
    triad_length: float

    @property
    def box_edges(self) -> np.ndarray:
        """The 12 box edges (12, 2, 3), or (0, 2, 3) without a box."""
        if self.box_corners is None:
            return np.empty((0, 2, 3))
        return np.array([[self.box_corners[i], self.box_corners[j]] for i, j in BOX_EDGES])

    def points(self) -> np.ndarray:
        """Every drawn point (m, 3), for axis limits."""
        parts = [self.joint_positions, self.segments, self.ee_segments, self.triads, self.box_edges]
        return np.concatenate([np.reshape(part, (-1, 3)) for part in parts])


@dataclass
class Drawing:
    """A drawn configuration: its geometry and the matplotlib lines (keys: links, joints, ee_links,
    triad_x, triad_y, triad_z, vehicle)."""

    geometry: ConfigurationGeometry
    artists: dict = field(default_factory=dict)
    plane: str | None = None


def _triad(pose: pin.SE3, length: float) -> np.ndarray:
    """The x, y, z axes of a pose as segments (3, 2, 3)."""
    return np.array([[pose.translation, pose.translation + length * pose.rotation[:, k]] for k in range(3)])


def configuration_geometry(robot: Robot, q: np.ndarray | Configuration, frames: Sequence[str] | None = None,
                           triad_length: float | None = None,
                           shapes: np.ndarray | None = None) -> ConfigurationGeometry:
    """World geometry of configuration q (nq,); ``triad_length`` [m] defaults to 8 % of the robot's extent (its
    joints, frames, vehicle box, the points (m, 3) [m] of ``shapes`` drawn with it, and the vehicle's
    :func:`body_size`), so the frames are seen on a vehicle of any size. ``q`` may be a Configuration of the robot
    (the one a loop over configurations moves)."""
    state = q if isinstance(q, Configuration) else Configuration(robot, q)
    model = robot.model
    frame_ids = [robot.frame_id(name) for name in (robot.ee_frames if frames is None else frames)]
    origins = np.array([state.joint_pose(j).translation for j in range(model.njoints)])  # (njoints, 3), universe = 0
    frame_poses = {f: state.pose(f) for f in frame_ids}
    first_arm = 1 if robot.base_type == "fixed" else 2
    segments = np.reshape([[origins[model.parents[j]], origins[j]] for j in range(first_arm, model.njoints)],
                          (-1, 2, 3))
    ee = np.reshape([[origins[model.frames[f].parentJoint], frame_poses[f].translation] for f in frame_ids],
                    (-1, 2, 3))
    box = vehicle_box(robot)
    vehicle_pose = state.joint_pose(1) if robot.base_type != "fixed" else None  # the vehicle joint's frame
    corners = None
    if box is not None:
        placement = vehicle_pose * pin.SE3(box.rotation, box.centre)
        corners = np.array([placement.act(sign * box.size / 2) for sign in CORNER_SIGNS])
    if triad_length is None:
        drawn = origins[first_arm - 1:]  # the world origin only under a fixed base (a vehicle may be far from it)
        shown = np.concatenate([drawn, ee.reshape(-1, 3), np.reshape([] if corners is None else corners, (-1, 3)),
                                np.reshape([] if shapes is None else shapes, (-1, 3))])
        triad_length = 0.08 * max(float(np.ptp(shown, axis=0).max()), body_size(robot), 0.1)
    poses = [frame_poses[f] for f in frame_ids] + ([vehicle_pose] if vehicle_pose is not None and box is None else [])
    triads = np.array([_triad(pose, triad_length * (2 if f >= len(frame_ids) else 1)) for f, pose in enumerate(poses)])
    return ConfigurationGeometry(list(model.names)[1:], origins[1:].copy(), segments, ee,
                                 triads.reshape(-1, 3, 2, 3), corners, float(triad_length))


def _polyline(segments: np.ndarray) -> np.ndarray:
    """Segments (k, 2, 3) as one polyline (3k, 3) with NaN rows between them (one artist for all)."""
    gaps = np.full((len(segments), 1, 3), np.nan)
    return np.concatenate([segments, gaps], axis=1).reshape(-1, 3)


def _line_data(geometry: ConfigurationGeometry) -> dict[str, np.ndarray]:
    lines = {"links": _polyline(geometry.segments), "joints": geometry.joint_positions,
             "ee_links": _polyline(geometry.ee_segments), "vehicle": _polyline(geometry.box_edges)}
    for k, axis in enumerate("xyz"):
        lines[f"triad_{axis}"] = _polyline(geometry.triads[:, k])
    return lines


def _coordinates(points: np.ndarray, plane: str | None) -> list[np.ndarray]:
    return [points[:, d] for d in (PLANES[plane] if plane else (0, 1, 2))]


def _set_line(line, points: np.ndarray, plane: str | None) -> None:
    if plane:
        line.set_data(*_coordinates(points, plane))
    else:
        line.set_data_3d(*_coordinates(points, plane))


def _check_axes(ax, plane: str | None) -> None:
    if plane is not None and plane not in PLANES:
        raise UVMSError(f"unknown plane {plane!r}; valid: {', '.join(PLANES)} or None (3-D)")
    if (getattr(ax, "name", "") == "3d") != (plane is None):
        raise UVMSError("plane=None draws on a 3-D Axes (projection='3d'); plane='xy'|'xz'|'yz' needs a 2-D Axes")


def set_equal_limits(ax, points: np.ndarray, plane: str | None = None, margin: float = 0.05) -> None:
    """Limits of a cube (square in 2-D) around ``points`` (m, 3) [m], equal scale on every axis."""
    coords = np.column_stack(_coordinates(points[np.all(np.isfinite(points), axis=1)], plane))
    low, high = coords.min(axis=0), coords.max(axis=0)
    centre, half = (low + high) / 2, max(float(np.max(high - low)) / 2 * (1 + margin), 1e-3)
    setters = (ax.set_xlim, ax.set_ylim, getattr(ax, "set_zlim", None))
    for setter, middle in zip(setters, centre):
        setter(middle - half, middle + half)
    if plane:
        ax.set_aspect("equal", adjustable="box")
    else:
        ax.set_box_aspect((1, 1, 1))
        for coordinate in (ax.xaxis, ax.yaxis, ax.zaxis):
            coordinate.set_major_locator(MaxNLocator(TICKS_3D))  # slanted tick labels clear of each other


def draw_configuration(ax, robot: Robot, q: np.ndarray, *, plane: str | None = None,
                       frames: Sequence[str] | None = None, triad_length: float | None = None,
                       color: str | None = None, vehicle_color: str = "tab:orange", linewidth: float = 2.0,
                       autoscale: bool = True) -> Drawing:
    """Draw configuration q (nq,) of ``robot`` as a stick figure on ``ax``.

    Args:
        ax: a 3-D Axes (``projection="3d"``) when ``plane`` is None, else a 2-D Axes.
        robot: the robot.
        q: configuration (nq,).
        plane: None (3-D) or "xy", "xz", "yz": the world projection to draw.
        frames: end-effector frames given a triad (default ``robot.ee_frames``).
        triad_length: triad axis length [m]; default 8 % of the robot's extent.
        color: colour of links and joints (default dark grey).
        vehicle_color: colour of the vehicle box.
        linewidth: link width [points].
        autoscale: set equal-aspect limits around the drawing.

    Returns:
        The Drawing (geometry and artists).

    Raises:
        ConfigurationError: q has the wrong size or is not a valid configuration.
        FrameNotFound: unknown frame name; UVMSError: bad plane or an Axes of the wrong kind.
    """
    _check_axes(ax, plane)
    geometry = configuration_geometry(robot, q, frames, triad_length)
    color = color or "0.2"
    styles = {"links": {"color": color, "linewidth": linewidth}, "ee_links": {"color": color, "linewidth": linewidth},
              "joints": {"color": color, "marker": "o", "markersize": 4, "linestyle": "none"},
              "vehicle": {"color": vehicle_color, "linewidth": 1.2}}
    styles.update({f"triad_{axis}": {"color": c, "linewidth": 1.5} for axis, c in zip("xyz", TRIAD_COLOURS)})
    artists = {name: ax.plot(*_coordinates(points, plane), **styles[name])[0]
               for name, points in _line_data(geometry).items()}
    labels = PLANES[plane] if plane else (0, 1, 2)
    for setter, index in zip((ax.set_xlabel, ax.set_ylabel, getattr(ax, "set_zlabel", None)), labels):
        setter(f"{'xyz'[index]} [m]")
    if autoscale:
        set_equal_limits(ax, geometry.points(), plane)
    return Drawing(geometry, artists, plane)


def legend_entries(geometry: ConfigurationGeometry, color: str = "0.2", vehicle_color: str = "tab:orange",
                   linewidth: float = 2.0) -> list[tuple]:
    """(handle, label) pairs that explain a drawing in the styles of :func:`draw_configuration`: links and joints,
    the vehicle box (when it has one), the frames' axes (x red, y green, z blue) as one entry."""
    entries = [(Line2D([], [], color=color, linewidth=linewidth, marker="o", markersize=4), "links and joints")]
    if geometry.box_corners is not None:
        entries.append((Line2D([], [], color=vehicle_color, linewidth=1.2), "vehicle box"))
    if len(geometry.triads):
        entries.append((tuple(Line2D([], [], color=c, linewidth=1.5) for c in TRIAD_COLOURS),
                        "frame axes: x red, y green, z blue"))
    return entries


def update_drawing(drawing: Drawing, geometry: ConfigurationGeometry) -> None:
    """Move the artists of a Drawing to another geometry of the same robot (an animation frame)."""
    for name, points in _line_data(geometry).items():
        _set_line(drawing.artists[name], points, drawing.plane)
    drawing.geometry = geometry


def as_configurations(robot: Robot, configurations) -> np.ndarray:
    """Configurations (N, nq), each checked; one q (nq,) counts as N = 1."""
    try:
        array = np.atleast_2d(np.asarray(configurations, dtype=float))
    except (TypeError, ValueError):
        raise ConfigurationError(f"configurations must be an array (N, {robot.nq}) of numbers") from None
    if array.ndim != 2 or len(array) == 0:
        raise ConfigurationError(f"configurations must be an array (N, {robot.nq}), N >= 1; got shape {array.shape}")
    for k, q in enumerate(array):
        try:
            robot.check_configuration(q)
        except ConfigurationError as exc:
            raise ConfigurationError(f"configuration {k}: {exc}") from None
    return array


def _new_axes(figure: Figure, grid: tuple[int, int, int], plane: str | None, view: tuple[float, float]):
    if plane:
        return figure.add_subplot(*grid)
    ax = figure.add_subplot(*grid, projection="3d")
    ax.view_init(elev=view[0], azim=view[1])
    return ax


def snapshot_figure(robot: Robot, configurations, *, titles: Sequence[str] | None = None,
                    path: str | os.PathLike | None = None, view: tuple[float, float] = (20.0, -60.0),
                    plane: str | None = None, ncols: int | None = None, frames: Sequence[str] | None = None,
                    panel_size: float = 4.0, overlay: CollisionOverlay | None = None) -> Figure:
    """Configuration snapshots (xiang2019 Figs. 7-8): a grid of panels on common equal-aspect limits, and a key
    below them (:func:`legend_entries`, and the overlay's :meth:`~CollisionOverlay.legend_entries`).

    Args:
        robot: the robot.
        configurations: (N, nq) array or sequence of q.
        titles: one per configuration.
        path: when given, the figure is written there atomically (format from the suffix).
        view: 3-D camera (elevation, azimuth) [deg].
        plane: None for 3-D panels, or "xy", "xz", "yz".
        ncols: panels per row (default min(N, 4)).
        frames: end-effector frames given a triad.
        panel_size: panel width and height [in].
        overlay: collision shapes, obstacles and closest pairs drawn over each panel (``uvms view --collision``).
    """
    qs = as_configurations(robot, configurations)
    if titles is not None and len(titles) != len(qs):
        raise UVMSError(f"got {len(titles)} titles for {len(qs)} configurations; give one per configuration")
    ncols = ncols or min(len(qs), 4)
    nrows = -(-len(qs) // ncols)
    figure = Figure(figsize=(panel_size * ncols, panel_size * nrows))
    triad = _first_geometry(robot, qs[0], frames, overlay).triad_length  # one length in every panel
    drawings = []
    for k, q in enumerate(qs):
        ax = _new_axes(figure, (nrows, ncols, k + 1), plane, view)
        drawings.append(draw_configuration(ax, robot, q, plane=plane, frames=frames, triad_length=triad,
                                           autoscale=False))
        if overlay is not None:
            overlay.draw(ax, q, plane)
        ax.set_title(titles[k] if titles is not None else f"configuration {k + 1}")
    points = np.concatenate([drawing.geometry.points() for drawing in drawings]
                            + ([overlay.points(q) for q in qs] if overlay is not None else []))
    for drawing, ax in zip(drawings, figure.axes[:len(drawings)]):
        set_equal_limits(ax, points, plane)
        if overlay is not None:
            overlay.draw_obstacles(ax, points, plane)
    entries = legend_entries(drawings[0].geometry) + (overlay.legend_entries() if overlay is not None else [])
    key = legend_below(figure, entries, columns=len(entries))
    height, margin = figure.bbox.height, LABEL_MARGIN * figure.dpi  # [px]
    figure.tight_layout(rect=(0.0, (key.get_window_extent().height + margin) / height, 1.0, 1.0 - margin / height))
    if path is not None:
        outputs.save_figure(figure, path)
    return figure


def _first_geometry(robot: Robot, q: np.ndarray, frames: Sequence[str] | None,
                    overlay: CollisionOverlay | None) -> ConfigurationGeometry:
    """The geometry of q, its triads sized with the overlay's shapes (the visual meshes of a vehicle alone)."""
    return configuration_geometry(robot, q, frames, shapes=None if overlay is None else overlay.points(q))


def _movie_writer(path: Path, fps: float) -> animation.AbstractMovieWriter:
    suffix = path.suffix.lower()
    if suffix not in WRITERS:
        raise UVMSError(f"cannot write an animation to {str(path)!r}: unknown suffix {suffix!r}; "
                        f"valid: {', '.join(WRITERS)}")
    if not fps > 0:
        raise UVMSError(f"fps must be positive, got {fps}")
    if suffix == ".mp4" and not animation.FFMpegWriter.isAvailable():
        raise UVMSError("mp4 needs ffmpeg on PATH; use a .gif path")
    return WRITERS[suffix](fps=fps)


def animate(robot: Robot, configurations, path: str | os.PathLike, *, fps: float = 20, times: np.ndarray | None = None,
            trail_frame: str | None = None, title: str = "", view: tuple[float, float] = (20.0, -60.0),
            plane: str | None = None, frames: Sequence[str] | None = None, figsize: tuple[float, float] = (6.0, 6.0),
            dpi: int = 80, progress: bool | None = None, overlay: CollisionOverlay | None = None) -> Path:
    """Write an animation of configurations (N, nq) to a ``.gif`` (Pillow) or ``.mp4`` (ffmpeg), atomically.

    The axis limits cover every frame, so the view does not jump.

    Args:
        robot: the robot.
        configurations: (N, nq) array, one frame each.
        path: output file; its suffix picks the writer.
        fps: frames per second.
        times: time of each frame (N,) [s], shown in the title.
        trail_frame: a frame whose path so far is drawn (e.g. an end effector).
        title: title prefix; view, plane, frames: as in :func:`snapshot_figure`.
        figsize: figure size [in]; dpi: its resolution.
        progress: show a progress bar (None: only on a terminal).
        overlay: collision shapes, obstacles and closest pairs drawn at each frame (``uvms view --collision``).

    Returns:
        The written path.

    Raises:
        UVMSError: unknown suffix, mp4 without ffmpeg, times of the wrong length; ConfigurationError: bad q.
    """
    path = Path(path)
    writer = _movie_writer(path, fps)
    qs = as_configurations(robot, configurations)
    if times is not None and np.shape(times) != (len(qs),):
        raise UVMSError(f"times must have shape ({len(qs)},) (one per configuration), got {np.shape(times)}")
    first = _first_geometry(robot, qs[0], frames, overlay)
    geometries = [first] + [configuration_geometry(robot, state, frames, first.triad_length)
                            for state in states.configurations(robot, qs[1:])]
    trail_id = robot.frame_id(trail_frame) if trail_frame else None
    trail = (np.array([state.pose(trail_id).translation.copy() for state in states.configurations(robot, qs)])
             if trail_frame else np.empty((0, 3)))
    figure = Figure(figsize=figsize)
    FigureCanvasAgg(figure)
    ax = _new_axes(figure, (1, 1, 1), plane, view)
    drawing = draw_configuration(ax, robot, qs[0], plane=plane, frames=frames, triad_length=first.triad_length,
                                 autoscale=False)
    shapes = [overlay.points(q) for q in qs] if overlay is not None else []
    points = np.concatenate([trail, *[geometry.points() for geometry in geometries], *shapes])
    set_equal_limits(ax, points, plane)
    if overlay is not None:
        overlay.draw_obstacles(ax, points, plane)
    marks = overlay.draw(ax, qs[0], plane) if overlay is not None else None
    trail_line = ax.plot(*_coordinates(trail[:1], plane), color="tab:purple", linestyle="--", linewidth=1)[0]

    def draw_frame(k: int) -> None:
        update_drawing(drawing, geometries[k])
        if marks is not None:
            overlay.move(marks, qs[k], plane)
        _set_line(trail_line, trail[: k + 1], plane)
        stamp = f"t = {times[k]:.2f} s" if times is not None else f"frame {k + 1}/{len(qs)}"
        ax.set_title(f"{title}  {stamp}".strip())

    movie = animation.FuncAnimation(figure, draw_frame, frames=len(qs), interval=1000 / fps, repeat=False,
                                    cache_frame_data=False)
    with tqdm(total=len(qs), disable=(not progress) if progress is not None else None, desc="animation",
              leave=False) as bar, \
            outputs.atomic_path(path, keep_suffix=True) as temporary:
        movie.save(temporary, writer=writer, dpi=dpi, progress_callback=lambda *_: bar.update(1))
    return path
