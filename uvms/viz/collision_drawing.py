"""Visual meshes, collision shapes, obstacles and closest pairs over a headless drawing (:mod:`uvms.viz.drawing`).

:class:`CollisionOverlay` is what ``uvms view --headless`` adds to :func:`~uvms.viz.drawing.snapshot_figure` and
:func:`~uvms.viz.drawing.animate`: the model's visual meshes (:mod:`uvms.viz.visual_shapes`, grey) without
``--collision``; with it (or ``--result`` of a run with collision objectives) the robot's collision shapes
(:mod:`uvms.viz.collision_shapes`) translucent, one collection per shape, at each drawn configuration; the
obstacles of the collision objectives, clipped to a box around the drawing (a pipe or a seabed plane runs beyond
it); and for each objective a segment between the witness points of its nearest pair, coloured by its distance
(red below the objective's ``min``), named with its distance in a legend below the panel (off the shapes).
:meth:`CollisionOverlay.legend_entries` explains the shapes, the obstacles and the colours in a figure's key.

In 3-D a shape is its hull's triangles (a ``Poly3DCollection``); in a plane (``"xy"``, ``"xz"``, ``"yz"``) the
outline of its projection (a ``PolyCollection`` of the 2-D hull). A visual mesh is its own triangles, projected in a
plane (it need not be convex).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin
from matplotlib.collections import PolyCollection
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

from ..model.collision import collision_geometry
from ..robot.robot import Robot
from ..tasks.objectives.collision import NearestPairs
from .collision_shapes import (
    PAIR_COLOURS,
    ClosestPair,
    ClosestPairs,
    ShapeMesh,
    geometry_meshes,
    obstacle_meshes,
)
from .labels import legend_under
from .visual_shapes import visual_meshes

#: Style of the robot's visual meshes, its collision shapes and the obstacles.
VISUAL_STYLE = {"facecolor": "0.62", "edgecolor": "0.45", "alpha": 0.35, "linewidth": 0.15}
SHAPE_STYLE = {"facecolor": "tab:cyan", "edgecolor": "tab:blue", "alpha": 0.22, "linewidth": 0.3}
OBSTACLE_STYLE = {"facecolor": "0.5", "edgecolor": "0.35", "alpha": 0.3, "linewidth": 0.3}
#: The obstacles are clipped to the box of the drawing's points grown by this fraction of its largest side.
CLIP_MARGIN = 0.5
PLANE_AXES = {"xy": (0, 1), "xz": (0, 2), "yz": (1, 2)}


@dataclass
class OverlayArtists:
    """The artists of a CollisionOverlay on one Axes: a collection per robot shape, a line per objective's closest
    pair, the legend below the Axes naming them (links, distance); ``closest`` the pairs drawn last."""

    shapes: list
    pairs: list
    legend: object | None
    closest: list[ClosestPair] = field(default_factory=list)


def outline(points: np.ndarray) -> np.ndarray:
    """The 2-D convex hull (k, 2) of points (n, 2), in order around it."""
    from scipy.spatial import ConvexHull, QhullError

    try:
        return points[ConvexHull(points).vertices]
    except (QhullError, ValueError):  # a shape seen edge-on (a flat plane): its extent as a thin segment
        return points[[int(np.argmin(points[:, 0] + points[:, 1])), int(np.argmax(points[:, 0] + points[:, 1]))]]


def clip_polygon(polygon: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """The part (k, 3) of a convex polygon (n, 3) [m] inside the box [lower, upper] (Sutherland-Hodgman)."""
    for axis in range(3):
        for bound, sign in ((lower[axis], 1.0), (upper[axis], -1.0)):
            if len(polygon) == 0:
                return polygon
            inside = sign * (polygon[:, axis] - bound) >= 0
            kept = []
            for k in range(len(polygon)):
                a, b = polygon[k], polygon[(k + 1) % len(polygon)]
                if inside[k]:
                    kept.append(a)
                if inside[k] != inside[(k + 1) % len(polygon)]:
                    kept.append(a + (bound - a[axis]) / (b[axis] - a[axis]) * (b - a))
            polygon = np.array(kept).reshape(-1, 3)
    return polygon


class CollisionOverlay:
    """What a drawing adds of the collision geometry (module docstring).

    Args:
        robot: the robot drawn.
        shapes: draw the robot's collision shapes (:func:`uvms.model.collision.collision_geometry`).
        objectives: collision objectives built on ``robot``: each one's nearest pair is marked, its obstacle drawn.
        visual: draw the robot's visual meshes (:func:`uvms.viz.visual_shapes.visual_meshes`), under the shapes.

    Raises:
        ModelCheckError: ``shapes`` and the robot's collision geometry cannot be built (no URDF, a missing mesh).

    Warns:
        MissingMeshWarning, GeometryWarning: ``visual`` and some visual meshes cannot be drawn (left out).
    """

    def __init__(self, robot: Robot, shapes: bool = True, objectives: Sequence[NearestPairs] = (),
                 visual: bool = False) -> None:
        self.robot = robot
        self.visuals: list[ShapeMesh] = visual_meshes(robot) if visual else []
        self.meshes: list[ShapeMesh] = geometry_meshes(collision_geometry(robot)) if shapes else []
        self.obstacles = obstacle_meshes(objectives)
        self.closest = ClosestPairs(robot, objectives)

    def robot_faces(self, q: np.ndarray) -> list[np.ndarray]:
        """The triangles (f, 3, 3) [m] of each visual mesh, then each collision shape, at configuration q (nq,)."""
        data = self.robot.model.createData()
        pin.forwardKinematics(self.robot.model, data, self.robot.check_configuration(q))
        return [mesh.faces(data.oMi[mesh.joint]) for mesh in self.visuals + self.meshes]

    def _polygons(self, index: int, faces: np.ndarray, plane: str) -> list[np.ndarray]:
        """The 2-D polygons of robot shape ``index`` (of :meth:`robot_faces`) in ``plane``: a visual mesh's
        triangles, a (convex) collision shape's outline."""
        axes = list(PLANE_AXES[plane])
        return list(faces[:, :, axes]) if index < len(self.visuals) else [outline(faces.reshape(-1, 3)[:, axes])]

    def points(self, q: np.ndarray) -> np.ndarray:
        """The robot shapes' vertices (m, 3) [m] at q (for the axis limits; obstacles are clipped to them)."""
        return np.concatenate([faces.reshape(-1, 3) for faces in self.robot_faces(q)] or [np.empty((0, 3))])

    def draw(self, ax, q: np.ndarray, plane: str | None = None) -> OverlayArtists:
        """Draw the robot shapes and the closest pairs at q (nq,) on ``ax`` (3-D when ``plane`` is None)."""
        shapes = []
        for index, faces in enumerate(self.robot_faces(q)):
            style = VISUAL_STYLE if index < len(self.visuals) else SHAPE_STYLE
            collection = (Poly3DCollection(faces, **style) if plane is None
                          else PolyCollection(self._polygons(index, faces, plane), **style))
            shapes.append(ax.add_collection3d(collection, autolim=False) if plane is None
                          else ax.add_collection(collection, autolim=False))
        pairs = [ax.plot(*[[0.0, 0.0]] * (3 if plane is None else 2), linewidth=2.5, marker="o", markersize=3)[0]
                 for _ in self.closest.objectives]
        artists = OverlayArtists(shapes, pairs, None)
        self.move(artists, q, plane, shapes=False)
        if pairs:  # below the Axes, clear of the shapes
            artists.legend = legend_under(ax, pairs, [pair.label() for pair in artists.closest])
        return artists

    def legend_entries(self) -> list[tuple]:
        """(handle, label) pairs of a figure's key: the robot's shapes, the obstacles, the closest pairs' colours."""
        entries = []
        if self.visuals:
            entries.append((Patch(**VISUAL_STYLE), "visual meshes"))
        if self.meshes:
            entries.append((Patch(**SHAPE_STYLE), "collision shapes"))
        if self.obstacles:
            entries.append((Patch(**OBSTACLE_STYLE), "obstacle"))
        if self.closest.objectives:
            marks = tuple(Line2D([], [], color=colour, linewidth=2.5, marker="o", markersize=3)
                          for colour in PAIR_COLOURS)
            entries.append((marks, "closest pair (red: < min, orange: < min + band, green: beyond)"))
        return entries

    def move(self, artists: OverlayArtists, q: np.ndarray, plane: str | None = None, shapes: bool = True) -> None:
        """Move the artists of :meth:`draw` to configuration q (nq,) (an animation frame)."""
        if shapes:
            for index, (collection, faces) in enumerate(zip(artists.shapes, self.robot_faces(q))):
                collection.set_verts(faces if plane is None else self._polygons(index, faces, plane))
        artists.closest = self.closest.at(q)
        for line, pair in zip(artists.pairs, artists.closest):
            ends = np.array([pair.point1, pair.point2])
            if plane is None:
                line.set_data_3d(ends[:, 0], ends[:, 1], ends[:, 2])
            else:
                line.set_data(ends[:, PLANE_AXES[plane][0]], ends[:, PLANE_AXES[plane][1]])
            line.set_color(pair.colour)
        if artists.legend is not None:
            for text, handle, pair in zip(artists.legend.get_texts(), artists.legend.legend_handles, artists.closest):
                text.set_text(pair.label())
                handle.set_color(pair.colour)

    def draw_obstacles(self, ax, points: np.ndarray, plane: str | None = None) -> list:
        """Draw the obstacles on ``ax`` after its limits are set, clipped to them (in a plane, the depth to the box
        of ``points`` (m, 3) [m] grown by :data:`CLIP_MARGIN`); one collection per obstacle that reaches into it."""
        finite = points[np.all(np.isfinite(points), axis=1)]
        if not self.obstacles or len(finite) == 0:
            return []
        low, high = finite.min(axis=0), finite.max(axis=0)
        grow = CLIP_MARGIN * float(np.max(high - low))
        low, high = low - grow, high + grow  # the depth of a plane's drawing
        limits = (ax.get_xlim(), ax.get_ylim(), ax.get_zlim()) if plane is None else (ax.get_xlim(), ax.get_ylim())
        for axis, (start, end) in zip((0, 1, 2) if plane is None else PLANE_AXES[plane], limits):
            low[axis], high[axis] = start, end  # what the Axes shows
        drawn = []
        for mesh in self.obstacles:
            polygons = [clip_polygon(face, low, high) for face in mesh.faces(pin.SE3.Identity())]
            polygons = [polygon for polygon in polygons if len(polygon) >= 3]
            if not polygons:
                continue
            if plane is None:
                drawn.append(ax.add_collection3d(Poly3DCollection(polygons, **OBSTACLE_STYLE), autolim=False))
            else:
                shadow = outline(np.concatenate(polygons)[:, PLANE_AXES[plane]])
                drawn.append(ax.add_collection(PolyCollection([shadow], **OBSTACLE_STYLE), autolim=False))
        return drawn
