"""Collision objectives from the model's ``<collision>`` geometry: the robot kept clear of itself and of obstacles.

Both keep the signed distance d of pairs of shapes at least ``min`` [m] (coal through Pinocchio's geometry
model, :mod:`uvms.model.collision` and :mod:`uvms.model.distances`; meshes as their convex hulls). At each step
the ``count`` nearest pairs are the objective's rows, nearest first, each with the distance Jacobian of its
witness points (d' = n . (v_p2 - v_p1)); pairs whose bounding spheres keep them farther are not queried.

Why the rows stay continuous when the nearest pair changes: row i holds the i-th smallest distance, a
continuous function of q (an order statistic of continuous distances), so its value, activation and reference
never jump. Two pairs trade rows only where their distances are equal, and the solvers treat the rows as a set
(an activation-weighted pseudo-inverse, a QP's constraints: a permutation of rows changes nothing). A pair enters
or leaves the last row where it ties with the pair it replaces; beyond ``min + band`` both have activation 0,
so the switch changes nothing either. ``count`` above the number of pairs that can be within the band at once
makes every switch happen at activation 0.

With the set-based solver give the level some damping (``solver.damping`` about 0.01): the nearest pairs' rows
are often nearly parallel (one shape between two others, two shapes of one link near one obstacle), and the
undamped inverse of nearly dependent rows lets the task through (measured on ``tests/fixtures/collision``'s
box_arm: 9 mm past ``min`` undamped, none with 0.01). The QP hierarchy needs none.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pinocchio as pin

from ...errors import FrameNotFound, LinkNotFound, ObjectiveError
from ...model.collision import (
    CollisionPairs,
    candidate_pairs,
    collision_geometry,
    collision_links,
    collision_pairs,
    geometry_link,
    pair_set,
)
from ...model.distances import Distances, PairDistances
from ...robot.configuration import Configuration
from ...robot.robot import Robot
from .base import Inequality, InequalityRows, finite_number
from .obstacles import obstacle_shape

#: Rows per pair: its witness and the points of the features tying with it
#: (:meth:`~uvms.model.distances.PairDistances.contact_points`).
POINTS = 5


class NearestPairs(Inequality):
    """The ``count`` nearest of a set of geometry pairs as rows d_i >= min, nearest first (module docstring).

    Attributes:
        distances: the pairs' :class:`~uvms.model.distances.PairDistances`; links: (link1, link2) of each pair.
    """

    collision = True

    distances: PairDistances
    links: list[tuple[str, str]]

    def _set_pairs(self, robot: Robot, geometry: pin.GeometryModel, pairs: np.ndarray, links: list,
                   min: float, band: float, count: int, gain: float, shape: str) -> None:  # noqa: A002
        """Store the pairs and the valid set: dim = min(count, number of pairs) rows >= min."""
        if len(pairs) == 0:
            raise ObjectiveError(f"{self.name}: no pair of shapes is left to check on {robot.name}")
        if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or count < 1:
            raise ObjectiveError(f"{self.name}: count must be a whole number >= 1 (rows: the nearest pairs), "
                                 f"got {count!r}")
        self.distances, self.links = PairDistances(robot.model, geometry, pairs), list(links)
        self.min = finite_number(min, f"{self.name}: min")
        self.pair_count = int(np.minimum(count, len(pairs)))
        dim = self.pair_count * POINTS
        self._set_valid_set(np.full(dim, self.min), np.full(dim, np.inf),
                            finite_number(band, f"{self.name}: band", positive=True), gain, shape)
        self._reach = self.min + float(self.band[0])  # beyond it a pair's rows are inactive: no contact points

    def nearest(self, state: Configuration) -> tuple[np.ndarray, Distances]:
        """(the pair (dim,) of each row; the rows' distances) at ``state``: the ``count`` nearest pairs, nearest
        first, each its witness then its :data:`POINTS` - 1 contact points (module docstring; the witness repeated
        for a pair farther than ``min + band``, where no row is active)."""
        chosen, found = self.distances.nearest(state, self.pair_count)
        near = np.flatnonzero(found.distance < self._reach)
        rows = np.repeat(np.arange(chosen.size), POINTS)  # each pair's witness, repeated
        fields = [np.array(field)[rows] for field in (found.distance, found.point1, found.point2, found.normal)]
        if near.size:
            points = self.distances.contact_points(state, chosen[near], found.take(near))
            for position, pair in enumerate(near.tolist()):
                block = slice(pair * POINTS + 1, (pair + 1) * POINTS)
                taken = slice(position * (POINTS - 1), (position + 1) * (POINTS - 1))
                for field, point_field in zip(fields, (points.distance, points.point1, points.point2,
                                                       points.normal)):
                    field[block] = point_field[taken]
        return chosen[rows], Distances(*fields)

    def nearest_pairs(self, state: Configuration) -> list[tuple[str, str, float]]:
        """(link1, link2, distance [m]) of the ``count`` nearest pairs at ``state``, nearest first (what to print or
        mark)."""
        chosen, found = self.distances.nearest(state, self.pair_count)
        return [(*self.links[k], float(d)) for k, d in zip(chosen, found.distance)]

    def value(self, state: Configuration) -> np.ndarray:
        return self.nearest(state)[1].distance

    def jacobian(self, state: Configuration) -> np.ndarray:
        return self.value_jacobian(state)[1]

    def value_jacobian(self, state: Configuration) -> tuple[np.ndarray, np.ndarray]:
        chosen, found = self.nearest(state)  # one distance query per pair for both
        return found.distance, self.distances.jacobian(state, found, chosen)

    def rows(self, state: Configuration) -> InequalityRows:
        """:meth:`Inequality.rows` with the pair of each row (what a recorder reports), from one query."""
        chosen, found = self.nearest(state)
        return self._rows(found.distance, self.distances.jacobian(state, found, chosen), chosen)


class SelfCollision(NearestPairs):
    """The robot clear of itself: the ``count`` nearest pairs of its collision shapes at least ``min`` apart.

    Args:
        robot: the model (its URDF ``<collision>`` shapes; meshes as convex hulls).
        min: the smallest distance allowed between two shapes [m].
        band: activation band [m] > 0.
        pairs: None: every pair of shapes on different, non-adjacent bodies minus those the model's SRDF disables
            (``srdf``, else ``<stem>.srdf`` beside the model), or without an SRDF those in collision at the
            neutral configuration (with a :class:`~uvms.errors.CollidingPairWarning`); ``"all"``: every
            pair of shapes on different, non-adjacent bodies; a list of [link1, link2]: the shapes of those links.
        count: rows: the nearest pairs kept (fewer if fewer pairs exist).
        gain: reference gain [1/s].
        shape: activation shape, "cosine" or "step".
        srdf: an SRDF file whose ``<disable_collisions>`` are left out (None: the one beside the model, if any).
        name: the name results report.

    Attributes:
        disabled: {(link1, link2): why} of the link pairs not checked (adjacent, same body, srdf, colliding).

    Raises:
        ObjectiveError: no pair left, a bad count, min, band or gain; a listed pair on one body or adjacent.
        LinkNotFound: a listed link that carries no collision shape (the message lists those that do).
        ModelCheckError: a missing or refused mesh, an unreadable SRDF.
    """

    type_name = "self_collision"
    min_metric = "min_self_distance"
    file_keys = ("srdf",)

    def __init__(self, robot: Robot, min: float = 0.01, band: float = 0.05,  # noqa: A002
                 pairs: str | Sequence[Sequence[str]] | None = None, count: int = 5, gain: float = 1.0,
                 shape: str = "cosine", srdf: str | os.PathLike | None = None, name: str = "self_collision") -> None:
        self.name = name
        geometry = collision_geometry(robot)
        if pairs is None:
            chosen = collision_pairs(robot, geometry, srdf=srdf)
        elif pairs == "all":
            chosen = candidate_pairs(robot, geometry)
        else:
            chosen = listed_pairs(robot, geometry, pairs, name)
        self.disabled = chosen.disabled
        self._set_pairs(robot, geometry, chosen.pairs, chosen.links, min, band, count, gain, shape)


def listed_pairs(robot: Robot, geometry: pin.GeometryModel, listed: object, name: str) -> CollisionPairs:
    """The geometry pairs of the link pairs ``listed`` ([[link1, link2], ...]), every shape of one link against every
    shape of the other.

    Raises:
        ObjectiveError: not a list of pairs of names, or two links that never move relative to each other or are
            adjacent (those pairs are never checked).
        LinkNotFound: a link without collision shapes.
    """
    if isinstance(listed, str) or not all(isinstance(pair, (list, tuple)) and len(pair) == 2
                                          and all(isinstance(link, str) for link in pair) for pair in listed):
        raise ObjectiveError(f"{name}: pairs must be None, 'all' or a list of [link1, link2], got {listed!r}")
    links = collision_links(robot, geometry)
    every = candidate_pairs(robot, geometry)
    kept = []
    for link1, link2 in listed:
        for link in (link1, link2):
            if link not in links:
                raise LinkNotFound(link, links, where=f"{name}: pair [{link1}, {link2}] (links with collision shapes)")
        why = every.disabled.get((link1, link2)) or every.disabled.get((link2, link1))
        if link1 == link2 or why is not None:
            raise ObjectiveError(f"{name}: the links {link1!r} and {link2!r} are {why or 'the same'}: their shapes "
                                 f"are never checked against each other; name links on bodies further apart")
        kept += [k for k, pair in enumerate(every.links) if set(pair) == {link1, link2}]
    return pair_set(robot, geometry, [tuple(every.pairs[k]) for k in kept], every.disabled)


class Obstacle(NearestPairs):
    """The robot clear of an obstacle fixed in the world: the ``count`` nearest of its shapes at least ``min`` from it.

    The obstacle's distance is signed: negative inside it. A ``plane`` is the half-space behind it (the seabed,
    a wall: everything on the side opposite the normal is solid).

    Args:
        robot: the model.
        geometry: "box" (``size`` [m], 3 sides), "sphere" (``radius``), "cylinder" (``radius``, ``length`` along its
            z axis), "plane" (``point``, ``normal`` towards the free side) or "mesh" (``mesh``: a mesh file, its
            convex hull; from a scenario, a path inside the scenario's folder).
        size, radius, length: the primitive's dimensions [m] > 0.
        point, normal: the plane's point (3,) [m] and normal (3,) (normalized here), world frame.
        position, rpy: the placement of a box, sphere, cylinder or mesh in the world: position (3,) [m] and roll,
            pitch, yaw (3,) [rad].
        mesh: the mesh file (.stl, .dae, .obj, .ply).
        frames: the frames kept clear: "all" (every collision shape of the robot that can move) or a list of frame
            names; a frame with collision shapes contributes them, another (an end effector) its origin as a point.
        min: the smallest distance allowed [m]; band: activation band [m] > 0.
        count: rows: the nearest shapes kept (fewer if fewer exist).
        gain: reference gain [1/s]; shape: activation shape, "cosine" or "step".
        name: the name results report (default ``obstacle(<geometry>)``).

    Raises:
        ObjectiveError: an unknown geometry, a missing, zero or non-finite dimension, a key the geometry does not
            take, a missing or refused mesh file, no shape to keep clear.
        FrameNotFound: an unknown frame (the message lists close names).
    """

    type_name = "obstacle"
    min_metric = "min_obstacle_distance"
    file_keys = ("mesh",)

    def __init__(self, robot: Robot, geometry: str, size: Sequence[float] | None = None, radius: float | None = None,
                 length: float | None = None, point: Sequence[float] | None = None,
                 normal: Sequence[float] | None = None, position: Sequence[float] = (0.0, 0.0, 0.0),
                 rpy: Sequence[float] = (0.0, 0.0, 0.0), mesh: str | os.PathLike | None = None,
                 frames: str | Sequence[str] = "all", min: float = 0.0, band: float = 0.1,  # noqa: A002
                 count: int = 5, gain: float = 1.0, shape: str = "cosine", name: str | None = None) -> None:
        self.name = name or f"obstacle({geometry})"
        solid, placement = obstacle_shape(self.name, geometry, size=size, radius=radius, length=length, point=point,
                                          normal=normal, position=position, rpy=rpy,
                                          mesh=None if mesh is None else Path(mesh))
        robot_geometry, kept = kept_clear(robot, frames, self.name)
        combined = robot_geometry.copy()
        obstacle = combined.addGeometryObject(pin.GeometryObject(self.name, 0, 0, placement, solid))
        pairs = np.array([[obstacle, k] for k in kept], dtype=int).reshape(-1, 2)
        links = [(self.name, geometry_link(robot, combined, k)) for k in kept]
        self._set_pairs(robot, combined, pairs, links, min, band, count, gain, shape)


def kept_clear(robot: Robot, frames: str | Sequence[str], name: str) -> tuple[pin.GeometryModel, list[int]]:
    """The robot's collision geometry with a point (a sphere of radius 0) added per named frame without shapes, and
    the indices of the shapes kept clear of an obstacle.

    Raises:
        ObjectiveError: ``frames`` neither "all" nor a list of names, or nothing to keep clear.
        FrameNotFound: an unknown frame.
    """
    import coal  # shipped with the pin wheel

    geometry = collision_geometry(robot) if robot.urdf is not None else pin.GeometryModel()
    objects = geometry.geometryObjects
    if frames == "all":
        kept = [k for k in range(geometry.ngeoms) if objects[k].parentJoint != 0]
        if not kept:
            raise ObjectiveError(f"{name}: {robot.name} has no collision shape that can move; name frames "
                                 f"(frames = [...]) to keep their origins clear")
        return geometry, kept
    if isinstance(frames, str) or not all(isinstance(frame, str) for frame in frames) or not frames:
        raise ObjectiveError(f"{name}: frames must be 'all' or a non-empty list of frame names, got {frames!r}")
    kept = []
    for frame in frames:
        if not robot.model.existFrame(frame):
            raise FrameNotFound(frame, robot.frame_names)
        shapes = [k for k in range(geometry.ngeoms) if geometry_link(robot, geometry, k) == frame]
        if not shapes:
            frame_id = robot.model.getFrameId(frame)
            item = robot.model.frames[frame_id]
            shapes = [geometry.addGeometryObject(pin.GeometryObject(frame, item.parentJoint, frame_id, item.placement,
                                                                    coal.Sphere(0.0)))]
        kept += shapes
    return geometry, kept
