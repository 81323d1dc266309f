"""Signed distances between pairs of collision geometries, their witness points, and the distance Jacobian.

For a pair (o1, o2) coal gives the signed distance d (negative: the penetration depth), the witness points p1
on o1 and p2 on o2 and the unit normal n from o1 to o2, all in the world frame, with d = n . (p2 - p1).
Moving each witness point with its body, d' = n . (v_p2 - v_p1), and the velocity of a point p carried by
joint i is v_p = J_v,i v - [p]x J_w,i v (``getJointJacobian`` in the WORLD frame: the velocity at the world
origin and the angular velocity), so the Jacobian row of the pair is

    J_d = n^T (J_v,2 - J_v,1) - (n x p2)^T J_w,2 + (n x p1)^T J_w,1       (1, nv), d' = J_d v.

:meth:`PairDistances.nearest` finds the k nearest pairs without querying every pair: each shape's bounding sphere
bounds its pair's distance, |c1 - c2| - r1 - r2 <= d <= |c1 - c2| + r1 + r2; the k-th smallest upper bound is a
reach no k-nearest pair exceeds, so only the pairs whose lower bound is within it are queried (one batch).

Contact points: the distance of two convex shapes is the smallest over their features (vertices, edges, faces) and
its gradient jumps where two features tie: a box's face parallel to an obstacle has four corners as near as its
witness, and the one row of the witness lets a solver turn the face so that the witness leaves while another
corner goes in (measured: ``bluerov2_alpha5_pipe`` without weights, the jaws' box 14 mm inside the pipe, the
witness switching edges every few steps). :meth:`PairDistances.contact_points` finds those features by turning the
second shape a little about its witness point (the perturbation a contact manifold is built with): the witness
points of the turned pair, the second turned back, are points of the features within reach, each a row
n . (p2_j - p1_j) with the witness normal (>= d, = d where it ties), its Jacobian the same formula.

A geometry on the world (joint 0: an obstacle, or a fixed base's root link) contributes nothing. The
Jacobian is that of smooth convex shapes (the normal's own rotation is second order in the distance); checked
against finite differences on the manifold in ``tests/model/test_distances.py``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..errors import ModelCheckError, NumericalError
from ..numerics.vectors import cross3
from ..robot.configuration import Configuration

#: GJK/EPA tolerance of the distance queries [m]: far below any clearance, and fine enough that the distance is
#: smooth at the scale of a finite-difference check.
DISTANCE_TOLERANCE = 1e-9
#: EPA tolerance of a penetration depth queried again [m]: EPA does not converge at 1e-9 on some deep
#: cylinder-cylinder overlaps (coal then returns -1.8e308; the Alpha 5's base tube through its E housing); at 1e-6 it
#: does.
RETRY_TOLERANCE = 1e-6
#: A penetration depth at 1e-9 is kept when the retry at 1e-6 agrees within this [m].
RETRY_AGREEMENT = 1e-5
#: A distance beyond this [m] is a failed query, not a distance (checked, never passed on).
LARGEST_DISTANCE = 1e6
#: The turn [rad] of a pair's second shape that finds the features tying with its witness
#: (:meth:`PairDistances.contact_points`): a feature whose gap to the witness is below tan(angle) times its lever
#: from the witness point is found.
CONTACT_ANGLE = 0.1

_X_AXIS, _Y_AXIS = np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])  # a tangent's seed, away from the normal


@dataclass(frozen=True)
class Distances:
    """Signed distances of m pairs at one configuration, world frame.

    Attributes:
        distance: (m,) [m], negative in penetration.
        point1, point2: (m, 3) witness points on the pair's first and second geometry [m].
        normal: (m, 3) unit normals from the first geometry to the second: distance = normal . (point2 - point1).
    """

    distance: np.ndarray
    point1: np.ndarray
    point2: np.ndarray
    normal: np.ndarray

    def take(self, rows: np.ndarray) -> Distances:
        """The distances of ``rows`` (k,) only."""
        return Distances(self.distance[rows], self.point1[rows], self.point2[rows], self.normal[rows])


def distance_request(tolerance: float = DISTANCE_TOLERANCE) -> object:
    """A coal distance request: signed, GJK and EPA to ``tolerance`` [m], GJK started from its default guess."""
    import coal  # shipped with the pin wheel

    request = coal.DistanceRequest()
    request.enable_signed_distance = True
    request.gjk_tolerance = request.epa_tolerance = tolerance
    return request


def fix_box_inflation() -> None:
    """Fix coal's box support inflation for the process: one query of an axis-aligned box along (1, 0, 0).

    coal's support function of a Box scales its negative half-sides by a factor kept in a function-local static,
    set by the process's FIRST Box support query: 1 + 1e-10 when that query's direction has a zero component, 1
    otherwise (coal 3.0, ``src/narrowphase/support_functions.cpp``, ``getShapeSupport(const Box*, ...)``: ``static
    const CoalScalar inflate = (dir.array() == 0).any() ? 1 + 1e-10 : 1.``). A process's signed distances to boxes
    then depend on which pair it queried first (~1e-11 m), and a solve on a box's tied corners turns that into
    centimetres within a few steps. This query comes first wherever uvms makes the process's first Box query, so
    every run, trial and test sees the same box (1 + 1e-10, the factor a run whose first query lies along an axis
    had before); once the static is set the query changes nothing (a few microseconds).
    """
    import coal  # shipped with the pin wheel

    coal.distance(coal.Box(1.0, 1.0, 1.0), coal.Transform3s(), coal.Capsule(0.1, 0.3),
                  coal.Transform3s(np.eye(3), np.array([3.0, 0.0, 0.0])), coal.DistanceRequest(),
                  coal.DistanceResult())


class PairDistances:
    """Signed distances and Jacobians of chosen pairs of a geometry model.

    Args:
        model: the robot's Pinocchio model; geometry: the geometry model (robot shapes, and obstacles attached to
            joint 0); pairs: (m, 2) indices of the geometry pairs evaluated.

    The geometry data is scratch filled at every :meth:`evaluate` (the placements recomputed from the
    configuration's joint placements, GJK started from its default guess, not the last call's): nothing carries
    over between calls.
    """

    def __init__(self, model: pin.Model, geometry: pin.GeometryModel, pairs: np.ndarray) -> None:
        self.model, self.pairs = model, np.asarray(pairs, dtype=int).reshape(-1, 2)
        self.geometry = geometry.copy()
        self.geometry.removeAllCollisionPairs()
        for a, b in self.pairs:
            self.geometry.addCollisionPair(pin.CollisionPair(int(a), int(b)))
        if len(self.geometry.collisionPairs) != len(self.pairs):
            raise ModelCheckError(f"the pairs of shapes must be distinct pairs of two shapes each, got "
                                  f"{self.pairs.tolist()}")
        self.joints = np.array([[geometry.geometryObjects[int(i)].parentJoint for i in pair] for pair in self.pairs],
                               dtype=int).reshape(-1, 2)
        self._moved = sorted(set(self.joints.ravel().tolist()) - {0})  # the joints that carry a shape; 0: the world
        self._entries = np.array([[self._moved.index(j) if j else -1 for j in pair] for pair in self.joints],
                                 dtype=np.int64).reshape(-1, 2)  # (m, 2): each side's joint in the table, -1: world
        self._data = pin.GeometryData(self.geometry)
        fix_box_inflation()  # before this object's first query (the process's first, where uvms queries first)
        for k in range(len(self.pairs)):  # Pinocchio's requests carry GJK's last guess between calls: fresh ones
            self._data.distanceRequests[k] = distance_request()
        # views of the results (a pass over the vector costs 1 us/pair)
        self._results = list(self._data.distanceResults)
        self._bounds = BoundingSpheres(geometry, self.pairs)

    @property
    def count(self) -> int:
        """Number of pairs m."""
        return len(self.pairs)

    def evaluate(self, state: Configuration) -> Distances:
        """Signed distances, witness points and normals of every pair at ``state`` (world frame)."""
        state.joint_pose(0)  # the joint placements (and Jacobians) at q, once per configuration
        pin.updateGeometryPlacements(self.model, state.data, self.geometry, self._data)
        self._data.setActiveCollisionPairs(self.geometry, np.ones((self.geometry.ngeoms,) * 2, dtype=bool))
        pin.computeDistances(self.geometry, self._data)
        return self._read(range(self.count))

    def nearest(self, state: Configuration, count: int) -> tuple[np.ndarray, Distances]:
        """(the indices (k,) of the ``count`` nearest pairs, nearest first, k = min(count, m); their Distances) at
        ``state``, querying only the pairs whose bounding spheres could be that near (module docstring)."""
        state.joint_pose(0)
        lower, upper = self._bounds.bounds(state)
        count = min(count, self.count)
        reach = np.partition(upper, count - 1)[count - 1]  # the count nearest are at most this far
        queried = np.flatnonzero(lower <= reach)  # every other pair is farther than all of them
        active = np.zeros((self.geometry.ngeoms, self.geometry.ngeoms), dtype=bool)
        active[self.pairs[queried, 0], self.pairs[queried, 1]] = True
        active |= active.T
        self._data.setActiveCollisionPairs(self.geometry, active)
        pin.updateGeometryPlacements(self.model, state.data, self.geometry, self._data)
        pin.computeDistances(self.geometry, self._data)
        indices, results = queried.tolist(), self._results
        # each distance read once; one outside [0, LARGEST_DISTANCE] (a penetration, a failed query) is checked
        found = np.array([value if 0.0 <= value <= LARGEST_DISTANCE else self._checked(k).min_distance
                          for k, value in zip(indices, [results[k].min_distance for k in indices])])
        chosen = queried[np.argsort(found, kind="stable")[:count]]
        return chosen, self._read(chosen.tolist())

    def _read(self, pairs: object) -> Distances:
        """The Distances of the last query of ``pairs`` (an iterable of pair indices)."""
        results = [self._checked(k) for k in pairs]
        return Distances(np.array([result.min_distance for result in results]),
                         np.array([result.getNearestPoint1() for result in results]).reshape(-1, 3),
                         np.array([result.getNearestPoint2() for result in results]).reshape(-1, 3),
                         np.array([result.normal for result in results]).reshape(-1, 3))

    def _checked(self, pair: int) -> object:
        """The last DistanceResult of ``pair``; a penetration is queried again at :data:`RETRY_TOLERANCE` and that
        result kept when the two disagree by more than :data:`RETRY_AGREEMENT` (EPA at 1e-9 can fail, returning
        -1.8e308, or stop at a wrong face: -142.8 mm for a jaw box 5.8 mm inside a pipe, which 1e-6 and the
        swapped pair both give).

        Raises:
            NumericalError: coal fails at that tolerance too (never a distance of -1.8e308 passed on).
        """
        import coal  # shipped with the pin wheel

        result = self._results[pair]
        if 0.0 <= result.min_distance <= LARGEST_DISTANCE:
            return result
        first, second = (int(i) for i in self.pairs[pair])
        objects, placements = self.geometry.geometryObjects, self._data.oMg
        retry = coal.DistanceResult()
        coal.distance(objects[first].geometry,
                      coal.Transform3s(placements[first].rotation, placements[first].translation),
                      objects[second].geometry,
                      coal.Transform3s(placements[second].rotation, placements[second].translation),
                      distance_request(RETRY_TOLERANCE), retry)
        if not abs(retry.min_distance) <= LARGEST_DISTANCE:
            raise NumericalError(f"coal cannot compute the distance between the shapes {objects[first].name!r} and "
                                 f"{objects[second].name!r} at this configuration "
                                 f"(it returned {retry.min_distance:g}); "
                                 f"they overlap deeply")
        agree = abs(result.min_distance - retry.min_distance) <= RETRY_AGREEMENT
        return result if agree else retry

    def contact_points(self, state: Configuration, rows: np.ndarray, distances: Distances,
                       angle: float = CONTACT_ANGLE) -> Distances:
        """The points of the features of pairs ``rows`` (k,) that tie with their witness: (k, 4) contact rows
        ``[k * 4 + j]`` as :class:`Distances`, each the pair's witness normal n with the witness points found after
        turning the pair's second shape by ``angle`` [rad] about its witness point p2 around +-t1, +-t2 (t1, t2
        orthogonal to n), the second point turned back with the shape (module docstring, "Contact points").

        Their distances n . (p2_j - p1_j) are >= the pair's distance (p1, p2 extreme along n on their shapes) and
        equal it for a tied feature; ``distances`` are those of ``rows`` at the same ``state`` (after
        :meth:`nearest` or :meth:`evaluate`, whose placements are read).
        """
        import coal  # shipped with the pin wheel

        objects, placements = self.geometry.geometryObjects, self._data.oMg
        request = distance_request()
        count = len(rows)
        out = np.empty((4 * count,)), np.empty((4 * count, 3)), np.empty((4 * count, 3)), np.empty((4 * count, 3))
        for position, pair in enumerate(np.asarray(rows, dtype=int).tolist()):
            first, second = (int(i) for i in self.pairs[pair])
            normal, p1, p2 = distances.normal[position], distances.point1[position], distances.point2[position]
            tangent = cross3(normal, _X_AXIS if abs(normal[0]) < 0.9 else _Y_AXIS)
            tangent /= math.sqrt(tangent.dot(tangent))  # numpy's norm: the square root of the dot product
            other = cross3(normal, tangent)
            shape1 = coal.Transform3s(placements[first].rotation, placements[first].translation)
            held = placements[second]
            for j, axis in enumerate((tangent, other, -tangent, -other)):
                turn = pin.exp3(angle * axis)  # about p2: x -> p2 + turn (x - p2)
                result = coal.DistanceResult()
                coal.distance(objects[first].geometry, shape1, objects[second].geometry,
                              coal.Transform3s(turn @ held.rotation, p2 + turn @ (held.translation - p2)), request,
                              result)
                row = 4 * position + j
                point1, point2 = result.getNearestPoint1(), p2 + turn.T @ (result.getNearestPoint2() - p2)
                if not abs(result.min_distance) <= LARGEST_DISTANCE:  # a failed query: the witness itself
                    point1, point2 = p1, p2
                out[0][row], out[1][row], out[2][row], out[3][row] = normal @ (point2 - point1), point1, point2, normal
        return Distances(*out)

    def jacobian(self, state: Configuration, distances: Distances, rows: np.ndarray) -> np.ndarray:
        """The distance Jacobian (k, nv), d' = J v, of the pairs ``rows`` (k,) (indices into the pairs) from their
        witness points and normals ``distances`` (k rows, those of ``rows`` at the same ``state``)."""
        from ..numerics._kernels.distance import distance_jacobian_into  # numba: loaded at the first use

        state.joint_pose(0)  # computeJointJacobians at q
        model, data = self.model, state.data
        table = np.empty((len(self._moved), 6, model.nv))
        for entry, joint in enumerate(self._moved):
            table[entry] = pin.getJointJacobian(model, data, joint, pin.ReferenceFrame.WORLD)
        rows = np.asarray(rows, dtype=np.int64)
        out = np.empty((rows.size, model.nv))
        distance_jacobian_into(table, self._entries[rows], distances.normal, distances.point1, distances.point2, out)
        return out


class BoundingSpheres:
    """The bounding sphere of each shape of the pairs, in its joint's frame, and the bounds of the pairs' distances
    they give at a configuration.

    Args:
        geometry: the geometry model; pairs: (m, 2) indices of its geometry pairs.
    """

    def __init__(self, geometry: pin.GeometryModel, pairs: np.ndarray) -> None:
        objects = geometry.geometryObjects
        used = sorted(set(pairs.ravel().tolist()))
        centres, radii, self.joints = [], [], []
        for index in used:
            item = objects[index]
            item.geometry.computeLocalAABB()
            radius = float(item.geometry.aabb_radius)
            finite = np.isfinite(radius)  # a half-space has no bounding sphere: its pairs are always queried
            centres.append(item.placement.act(np.asarray(item.geometry.aabb_center)) if finite else np.zeros(3))
            radii.append(radius)
            self.joints.append(item.parentJoint)
        self.centres, self.radii = np.array(centres).reshape(-1, 3), np.array(radii)
        position = {index: k for k, index in enumerate(used)}
        self.sides = np.array([[position[int(i)] for i in pair] for pair in pairs], dtype=np.int64).reshape(-1, 2)
        self.moved = sorted(set(self.joints))
        self.carrier = np.array([self.moved.index(joint) for joint in self.joints], dtype=np.int64)  # (g,)

    def bounds(self, state: Configuration) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper) bounds (m,) [m] of every pair's distance at ``state``: |c1 - c2| -+ (r1 + r2) (-inf and
        +inf for a pair with a half-space)."""
        from ..numerics._kernels.distance import sphere_bounds_into  # numba: loaded at the first use

        rotation, translation = np.empty((len(self.moved), 3, 3)), np.empty((len(self.moved), 3))
        for entry, joint in enumerate(self.moved):
            placement = state.joint_pose(joint)
            rotation[entry], translation[entry] = placement.rotation, placement.translation
        lower, upper = np.empty(len(self.sides)), np.empty(len(self.sides))
        sphere_bounds_into(rotation, translation, self.carrier, self.centres, self.radii, self.sides, lower, upper)
        return lower, upper
