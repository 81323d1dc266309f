"""Collision shapes as triangle meshes, and the closest pair of each collision objective, for the drawings.

What :mod:`uvms.viz.collision_drawing` (matplotlib) and the browser viewer (:mod:`uvms.viz.viewer.geometry`) show
of the collision geometry the objectives check (:func:`uvms.model.collision.collision_geometry`: boxes, spheres,
cylinders, capsules, meshes as their convex hulls): every shape is convex, so it is drawn as the convex hull of
points on its surface (coal's Qhull): a box's 8 corners, a cylinder's two rings of :data:`RING_POINTS`, a sphere's
and a capsule's rings of latitude; a mesh's hull as it is. A plane (an obstacle's half-space) is a square of side
:data:`PLANE_SIDE` on it, clipped to the drawing.

:class:`ClosestPairs` marks, at a configuration, the nearest pair of each
:class:`~uvms.tasks.objectives.collision.NearestPairs` objective: its witness points (coal's, through
:meth:`~uvms.tasks.objectives.collision.NearestPairs.nearest`), its distance and a colour: red below the objective's
``min``, orange inside its band (the objective acts), green beyond.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..errors import UVMSError
from ..robot.configuration import Configuration
from ..robot.robot import Robot
from ..tasks.objectives.collision import NearestPairs, Obstacle

#: Points per ring of a cylinder, sphere or capsule drawn as a hull (a 24-gon: 1 % short of the circle's radius at
#: worst, at the middle of an edge).
RING_POINTS = 24
#: Side of the square drawn for a plane obstacle (half-space) [m], before it is clipped to the drawing.
PLANE_SIDE = 100.0
#: Colours of a closest pair: below min, inside the band, beyond the band.
PAIR_COLOURS = ("tab:red", "tab:orange", "tab:green")


@dataclass(frozen=True)
class ShapeMesh:
    """A convex shape as a triangle mesh in its joint's frame.

    Attributes:
        name: the geometry object's name; joint: the joint carrying it (0: the world).
        vertices: (k, 3) [m] in the joint frame; triangles: (f, 3) indices into ``vertices``.
    """

    name: str
    joint: int
    vertices: np.ndarray
    triangles: np.ndarray

    def faces(self, joint_pose: pin.SE3) -> np.ndarray:
        """The triangles (f, 3, 3) [m] in the world, the joint at ``joint_pose``."""
        world = self.vertices @ joint_pose.rotation.T + joint_pose.translation
        return world[self.triangles]


def ring(radius: float, z: float) -> np.ndarray:
    """:data:`RING_POINTS` points (n, 3) on a circle of ``radius`` [m] about the z axis at height ``z`` [m]."""
    angle = np.linspace(0.0, 2 * np.pi, RING_POINTS, endpoint=False)
    return np.column_stack([radius * np.cos(angle), radius * np.sin(angle), np.full(RING_POINTS, z)])


def rounded_points(radius: float, half_length: float) -> np.ndarray:
    """Points on a sphere of ``radius`` [m] (half_length 0) or a capsule (its two caps ``half_length`` [m] from the
    centre along z): rings of latitude every 15 degrees and the poles."""
    latitudes = np.linspace(-np.pi / 2, np.pi / 2, 13)[1:-1]
    rings = [ring(radius * np.cos(a), radius * np.sin(a) + np.sign(a) * half_length) for a in latitudes]
    rings += [ring(radius, -half_length), ring(radius, half_length)]
    poles = [[0.0, 0.0, -radius - half_length], [0.0, 0.0, radius + half_length]]
    return np.concatenate([*rings, poles])


def surface_points(shape: object) -> np.ndarray:
    """Points (k, 3) [m] whose convex hull is the convex coal ``shape`` (up to :data:`RING_POINTS`), shape frame.

    Raises:
        UVMSError: a shape that is neither a box, sphere, cylinder, capsule, cone nor a convex mesh.
    """
    import coal  # shipped with the pin wheel

    if isinstance(shape, coal.Box):
        return np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * shape.halfSide
    if isinstance(shape, coal.Sphere):
        return rounded_points(shape.radius, 0.0)
    if isinstance(shape, coal.Capsule):
        return rounded_points(shape.radius, shape.halfLength)
    if isinstance(shape, coal.Cylinder):
        return np.concatenate([ring(shape.radius, -shape.halfLength), ring(shape.radius, shape.halfLength)])
    if isinstance(shape, coal.Cone):
        return np.concatenate([ring(shape.radius, -shape.halfLength), [[0.0, 0.0, shape.halfLength]]])
    if isinstance(shape, coal.ConvexBase):
        return np.asarray(shape.points(), dtype=float).reshape(-1, 3)
    raise UVMSError(f"cannot draw a collision shape of type {type(shape).__name__}; the drawn shapes are boxes, "
                    f"spheres, cylinders, capsules, cones and convex meshes")


def hull_mesh(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(vertices (k, 3), triangles (f, 3)) of the convex hull of ``points`` (n, 3) (coal's Qhull)."""
    import coal  # shipped with the pin wheel

    listed = coal.StdVec_Vec3s()
    listed.extend([np.asarray(point, dtype=float) for point in points])
    hull = coal.ConvexBase.convexHull(listed, True, "Qt")
    triangles = np.array([[hull.polygons(k)[i] for i in range(3)] for k in range(hull.num_polygons)], dtype=int)
    return np.asarray(hull.points(), dtype=float).reshape(-1, 3), triangles


def plane_mesh(shape: object) -> tuple[np.ndarray, np.ndarray]:
    """A square of side :data:`PLANE_SIDE` on a coal Halfspace (n . x = d), centred at its point nearest the
    origin, as two triangles."""
    normal = np.asarray(shape.n, dtype=float)
    side = np.cross(normal, [1.0, 0.0, 0.0] if abs(normal[0]) < 0.9 else [0.0, 1.0, 0.0])
    side /= np.linalg.norm(side)
    other = np.cross(normal, side)
    centre = shape.d * normal
    corners = [centre + PLANE_SIDE / 2 * (a * side + b * other) for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    return np.array(corners), np.array([[0, 1, 2], [0, 2, 3]])


def shape_mesh(item: pin.GeometryObject) -> ShapeMesh:
    """The ShapeMesh of a geometry object (its placement on its joint applied)."""
    import coal  # shipped with the pin wheel

    if isinstance(item.geometry, coal.Halfspace):
        vertices, triangles = plane_mesh(item.geometry)
    elif isinstance(item.geometry, coal.ConvexBase) and item.geometry.num_polygons:
        polygons = [item.geometry.polygons(k) for k in range(item.geometry.num_polygons)]
        vertices = np.asarray(item.geometry.points(), dtype=float).reshape(-1, 3)
        triangles = np.array([[polygon[i] for i in range(3)] for polygon in polygons], dtype=int)
    else:
        vertices, triangles = hull_mesh(surface_points(item.geometry))
    placed = vertices @ item.placement.rotation.T + item.placement.translation
    return ShapeMesh(item.name, int(item.parentJoint), placed, triangles)


def geometry_meshes(geometry: pin.GeometryModel, indices: Sequence[int] | None = None) -> list[ShapeMesh]:
    """The ShapeMesh of every object of ``geometry`` (or of ``indices``), in order."""
    chosen = range(geometry.ngeoms) if indices is None else indices
    return [shape_mesh(geometry.geometryObjects[int(k)]) for k in chosen]


def obstacle_meshes(objectives: Sequence[NearestPairs]) -> list[ShapeMesh]:
    """The world-fixed shapes of the :class:`~uvms.tasks.objectives.collision.Obstacle` objectives (each
    objective's pairs hold its obstacle first)."""
    meshes = []
    for objective in objectives:
        if isinstance(objective, Obstacle):
            held = sorted(set(objective.distances.pairs[:, 0].tolist()))
            meshes += geometry_meshes(objective.distances.geometry, held)
    return meshes


# ------------------------------------------------------------------ closest pairs
@dataclass(frozen=True)
class ClosestPair:
    """The nearest pair of one collision objective at a configuration.

    Attributes:
        objective: its name; links: (link1, link2) (an obstacle's name first); distance: signed [m];
        point1, point2: the witness points (3,) [m], world frame; colour: a matplotlib colour name
        (:data:`PAIR_COLOURS`).
    """

    objective: str
    links: tuple[str, str]
    distance: float
    point1: np.ndarray
    point2: np.ndarray
    colour: str

    def label(self) -> str:
        """``self_collision: link1 / link2 12.3 mm``."""
        return f"{self.objective}: {' / '.join(self.links)} {1000 * self.distance:.1f} mm"


def pair_colour(distance: float, minimum: float, band: float) -> str:
    """:data:`PAIR_COLOURS`: red below ``minimum`` [m], orange within ``band`` [m] above it, green beyond."""
    return PAIR_COLOURS[0] if distance < minimum else PAIR_COLOURS[1] if distance < minimum + band else PAIR_COLOURS[2]


class ClosestPairs:
    """The nearest pair of each of some collision objectives, at any configuration of their robot.

    Args:
        robot: the robot the objectives were built on; objectives: self_collision and obstacle objectives.
    """

    def __init__(self, robot: Robot, objectives: Sequence[NearestPairs]) -> None:
        self.robot, self.objectives = robot, list(objectives)

    def at(self, q: np.ndarray) -> list[ClosestPair]:
        """The nearest pair of each objective at configuration q (nq,), in the objectives' order."""
        state = Configuration(self.robot, q)
        pairs = []
        for objective in self.objectives:
            chosen, found = objective.nearest(state)
            distance = float(found.distance[0])
            pairs.append(ClosestPair(objective.name, tuple(objective.links[int(chosen[0])]), distance,
                                     found.point1[0].copy(), found.point2[0].copy(),
                                     pair_colour(distance, objective.min, float(objective.band[0]))))
        return pairs
