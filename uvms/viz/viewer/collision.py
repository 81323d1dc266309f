"""The collision geometry in the browser viewer: the shapes the collision objectives check, and their closest pairs.

:func:`viewer_collision_model` is the viewer's collision model: :func:`uvms.model.collision.collision_geometry` (what
the objectives check: meshes as their convex hulls, capsules included) with every shape as the triangle mesh of
:mod:`uvms.viz.collision_shapes` (a ``coal.Convex``, which Pinocchio's viser viewer draws for any shape), translucent.
:class:`CollisionControls` is the panel's "Collision shapes" checkbox (viser's visibility of the collision model) and
the segments between the witness points of each objective's closest pair at the configuration shown.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence

import numpy as np
import pinocchio as pin
from matplotlib.colors import to_rgb

from ...errors import GeometryWarning, ModelCheckError
from ...model.collision import collision_geometry
from ...robot.robot import Robot
from ..collision_shapes import ClosestPair, shape_mesh

#: RGBA of the collision shapes in the viewer.
COLLISION_COLOUR = np.array([0.1, 0.65, 0.85, 0.35])
#: The scene node of the closest-pair segments; their width [m].
CLOSEST_NODE, CLOSEST_WIDTH = "/closest_pairs", 0.006
#: Order of the checkbox in the panel (after the teach panel's reset button).
ORDER_COLLISION = 60.0


def convex_mesh(vertices: np.ndarray, triangles: np.ndarray) -> object:
    """A ``coal.Convex`` of a triangle mesh: vertices (k, 3) [m], triangles (f, 3)."""
    import coal  # shipped with the pin wheel

    points, faces = coal.StdVec_Vec3s(), coal.StdVec_Triangle()
    points.extend([np.asarray(vertex, dtype=float) for vertex in vertices])
    faces.extend([coal.Triangle(*(int(i) for i in face)) for face in triangles])
    return coal.Convex(points, faces)


def viewer_collision_model(robot: Robot) -> pin.GeometryModel:
    """The collision shapes the objectives check, as meshes the viewer draws (module docstring); an empty model,
    with a :class:`~uvms.errors.GeometryWarning`, when the robot's collision geometry cannot be built (and
    silently for a robot without a URDF: it has no collision shapes)."""
    if robot.urdf is None:
        return pin.GeometryModel()
    try:
        geometry = collision_geometry(robot)
    except ModelCheckError as exc:
        warnings.warn(f"the collision shapes are not shown: {' '.join(str(exc).split())}", GeometryWarning,
                      stacklevel=2)
        return pin.GeometryModel()
    shown = pin.GeometryModel()
    for item in geometry.geometryObjects:
        mesh = shape_mesh(item)  # vertices in the joint frame: the placement is in them
        copy = pin.GeometryObject(item.name, item.parentJoint, item.parentFrame, pin.SE3.Identity(),
                                  convex_mesh(mesh.vertices, mesh.triangles))
        copy.meshColor = COLLISION_COLOUR
        shown.addGeometryObject(copy)
    return shown


class CollisionControls:
    """The panel's "Collision shapes" checkbox and the closest-pair segments of a viewer.

    Args:
        server: the viser server; visualizer: Pinocchio's ViserVisualizer of the robot.
        shown: whether the collision shapes are shown at first.
        refresh: shows the current configuration again (the shapes are placed only while visible).

    Attributes:
        checkbox: the viser checkbox; segments: the scene handle of the last marked pairs (None: none marked).
    """

    def __init__(self, server, visualizer, shown: bool, refresh: Callable[[], None]) -> None:
        self.server, self.visualizer, self._refresh = server, visualizer, refresh
        self.checkbox = server.gui.add_checkbox("Collision shapes", initial_value=bool(shown), order=ORDER_COLLISION,
                                                hint="the <collision> shapes the collision objectives check")
        self.checkbox.on_update(lambda _event: self.show(bool(self.checkbox.value)))
        self.segments = None
        visualizer.displayCollisions(bool(shown))  # placed by the viewer's next display

    @property
    def shown(self) -> bool:
        """Whether the collision shapes are visible."""
        return bool(self.visualizer.collisionRootFrame.visible)

    def show(self, visible: bool) -> None:
        """Show or hide the collision shapes (the checkbox follows)."""
        self.visualizer.displayCollisions(visible)
        if self.checkbox.value != visible:
            self.checkbox.value = visible
        if visible:
            self._refresh()

    def mark(self, pairs: Sequence[ClosestPair]) -> None:
        """Draw a segment between the witness points of each pair, in its colour (none: remove them)."""
        if not pairs:
            if self.segments is not None:
                self.segments.remove()
                self.segments = None
            return
        points = np.array([[pair.point1, pair.point2] for pair in pairs])  # (n, 2, 3)
        colours = np.repeat(np.array([to_rgb(pair.colour) for pair in pairs])[:, None, :], 2, axis=1)
        self.segments = self.server.scene.add_line_segments(CLOSEST_NODE, points, colours, thickness=CLOSEST_WIDTH)

    def remove(self) -> None:
        """Take the checkbox and the segments off the page."""
        self.checkbox.remove()
        self.mark([])
