"""Collision geometry of a model: its URDF ``<collision>`` shapes, and the pairs of them that are checked.

:func:`collision_geometry` builds a ``pinocchio.GeometryModel`` from the URDF's ``<collision>`` elements
(``pin.buildGeomFromUrdfString``; boxes, spheres, cylinders and capsules stay coal primitives). A mesh is
**reduced to its convex hull** (coal's ``buildConvexHull``, Qhull): coal's signed distance (GJK/EPA) needs
convex shapes, and a hull is a conservative stand-in (never inside the mesh). A shape on a link joined to its
parent by a fixed (or frozen) joint is attached to the joint that carries that link, at the link's placement
(Pinocchio places it through the link's frame).

:func:`collision_pairs` chooses the pairs of geometries checked against each other: every two geometries on
different links, minus

* geometries on the same joint body (links joined by fixed joints never move relative to each other), and on
  adjacent joint bodies (a joint and its parent in Pinocchio's kinematic tree: their shapes meet at the joint);
* the link pairs an SRDF disables (``<disable_collisions link1= link2= />``): the one given, else one beside
  the model (``<stem>.srdf`` in the model's folder, or in a sibling ``srdf/`` folder, the ROS layout), read as
  untrusted data (:func:`read_srdf`);
* without an SRDF, the pairs in collision at a reference configuration (the robot's neutral one, or one given),
  with a :class:`CollidingPairWarning` naming them (``CollisionPairs.disabled`` holds them and why).
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin

from ..errors import CollidingPairWarning, LinkNotFound, ModelCheckError, UVMSError
from ..robot.robot import Robot
from .meshes import resolved_urdf
from .resources import read_file

#: The largest SRDF read [bytes]: 1 MiB (example-robot-data's largest is 6 KiB).
MAX_SRDF_BYTES = 1 << 20
#: Why a pair of links is not checked (the values of ``CollisionPairs.disabled``).
SAME_BODY, ADJACENT, SRDF, COLLIDING = "same body", "adjacent", "srdf", "in collision at the reference configuration"


def collision_geometry(robot: Robot) -> pin.GeometryModel:
    """The robot's ``<collision>`` shapes as a GeometryModel, meshes reduced to their convex hulls.

    Raises:
        ModelCheckError: the robot has no URDF, a mesh is missing or refused
            (:func:`uvms.model.meshes.resolved_urdf`), Pinocchio cannot read a shape, or a mesh has no volume.
    """
    if robot.urdf is None:
        raise ModelCheckError(f"{robot.name}: the robot has no URDF, so no <collision> geometry; load it from a "
                              f"URDF/xacro file")
    xml, _ = resolved_urdf(robot, strict=True)
    root = ET.fromstring(xml)
    capsules = without_capsules(root)
    try:
        geometry = pin.buildGeomFromUrdfString(robot.model, ET.tostring(root, encoding="unicode"),
                                               pin.GeometryType.COLLISION)
    except (RuntimeError, ValueError) as exc:
        raise ModelCheckError(f"{robot.source}: Pinocchio cannot read the <collision> geometry "
                              f"({' '.join(str(exc).split())})") from None
    for item in geometry.geometryObjects:
        item.geometry = convex_shape(item.geometry, f"{robot.source}: collision {item.name!r} ({item.meshPath})")
    for link, index, element in capsules:
        geometry.addGeometryObject(capsule_object(robot, link, index, element))
    return geometry


def without_capsules(root: ET.Element) -> list[tuple[str, int, ET.Element]]:
    """Take the ``<collision>`` elements holding a ``<capsule>`` out of the URDF tree ``root`` (Pinocchio's URDF
    parser drops them): (link, index of the collision in its link, the element) of each."""
    taken = []
    for link in root.iter("link"):
        for index, element in enumerate(list(link.findall("collision"))):
            if element.find("geometry/capsule") is not None:
                taken.append((link.get("name", ""), index, element))
                link.remove(element)
    return taken


def capsule_object(robot: Robot, link: str, index: int, element: ET.Element) -> pin.GeometryObject:
    """The GeometryObject of a URDF ``<collision>`` capsule (radius, length of its cylindrical part [m], along its z
    axis), attached as Pinocchio attaches the other shapes: to the joint of the link's frame."""
    import coal  # shipped with the pin wheel

    capsule = element.find("geometry/capsule")
    radius, length = (float(capsule.get(key, "nan")) for key in ("radius", "length"))
    if not (radius > 0 and length >= 0 and np.isfinite(radius + length)):
        raise ModelCheckError(f"{robot.source}: link {link!r}: a <capsule> needs radius > 0 and length >= 0 [m], got "
                              f"{dict(capsule.attrib)}")
    origin = element.find("origin")
    xyz = [float(x) for x in (origin.get("xyz", "0 0 0") if origin is not None else "0 0 0").split()]
    rpy = [float(x) for x in (origin.get("rpy", "0 0 0") if origin is not None else "0 0 0").split()]
    frame = robot.model.frames[robot.model.getFrameId(link, pin.FrameType.BODY)]
    placement = frame.placement * pin.SE3(pin.rpy.rpyToMatrix(*rpy), np.array(xyz))
    return pin.GeometryObject(f"{link}_{index}", frame.parentJoint, robot.model.getFrameId(link, pin.FrameType.BODY),
                              placement, coal.Capsule(radius, length))


def convex_shape(shape: object, where: str) -> object:
    """A coal shape fit for signed distances: a mesh (BVH) replaced by its convex hull, a primitive as it is.

    Raises:
        ModelCheckError: the mesh is flat or empty (Qhull finds no hull with a volume).
    """
    import coal  # shipped with the pin wheel

    if not isinstance(shape, coal.BVHModelBase):
        return shape
    vertices = np.asarray(shape.vertices(), dtype=float).reshape(-1, 3)
    if not spans_a_volume(vertices):  # checked first: Qhull on a flat mesh crashes the process
        raise ModelCheckError(f"{where}: the mesh is flat or empty ({len(vertices)} vertices spanning no volume, or "
                              f"a zero scale); a collision mesh needs a volume")
    try:
        shape.buildConvexHull(True, "Qt")
    except (RuntimeError, ValueError) as exc:
        raise ModelCheckError(f"{where}: the mesh has no convex hull with a volume: "
                              f"{' '.join(str(exc).split())}") from None
    hull = shape.convex
    if hull is None or hull.computeVolume() <= 0:
        raise ModelCheckError(f"{where}: the mesh's convex hull has no volume (flat, or a zero scale)")
    return hull


def spans_a_volume(vertices: np.ndarray) -> bool:
    """Whether points (n, 3) [m] span three dimensions: their spread along the thinnest principal axis above 1e-9
    of the widest (and the points finite)."""
    if len(vertices) < 4 or not np.all(np.isfinite(vertices)):
        return False
    spread = np.linalg.svd(vertices - vertices.mean(axis=0), compute_uv=False)
    return bool(spread[0] > 0 and spread[2] > 1e-9 * spread[0])


def geometry_link(robot: Robot, geometry: pin.GeometryModel, index: int) -> str:
    """The link (frame name) a geometry object belongs to."""
    return robot.model.frames[geometry.geometryObjects[index].parentFrame].name


def collision_links(robot: Robot, geometry: pin.GeometryModel) -> list[str]:
    """The links that carry collision geometry, in the order of the geometry model."""
    return list(dict.fromkeys(geometry_link(robot, geometry, i) for i in range(geometry.ngeoms)))


# ------------------------------------------------------------------ pairs
@dataclass(frozen=True)
class CollisionPairs:
    """The geometry pairs checked, and the link pairs left out.

    Attributes:
        pairs: (m, 2) indices into the geometry model of the pairs checked.
        links: (link1, link2) of each pair checked.
        disabled: {(link1, link2): why} of the link pairs left out (:data:`SAME_BODY`, :data:`ADJACENT`,
            :data:`SRDF`, :data:`COLLIDING`), link names in the geometry model's order.
    """

    pairs: np.ndarray
    links: list[tuple[str, str]]
    disabled: dict[tuple[str, str], str] = field(default_factory=dict)


def candidate_pairs(robot: Robot, geometry: pin.GeometryModel) -> CollisionPairs:
    """Every pair of geometries on different, non-adjacent joint bodies, and the link pairs this leaves out."""
    parents, objects = robot.model.parents, geometry.geometryObjects
    kept, disabled = [], {}
    for a in range(geometry.ngeoms):
        for b in range(a + 1, geometry.ngeoms):
            ja, jb = objects[a].parentJoint, objects[b].parentJoint
            links = (geometry_link(robot, geometry, a), geometry_link(robot, geometry, b))
            if ja == jb:
                disabled[links] = SAME_BODY
            elif parents[ja] == jb or parents[jb] == ja:
                disabled[links] = ADJACENT
            else:
                kept.append((a, b))
    return pair_set(robot, geometry, kept, disabled)


def pair_set(robot: Robot, geometry: pin.GeometryModel, kept: Sequence[tuple[int, int]],
             disabled: dict[tuple[str, str], str]) -> CollisionPairs:
    """The CollisionPairs of the geometry pairs ``kept`` (their links named)."""
    return CollisionPairs(np.array(kept, dtype=int).reshape(-1, 2),
                          [(geometry_link(robot, geometry, int(a)), geometry_link(robot, geometry, int(b)))
                           for a, b in kept],
                          dict(disabled))


def collision_pairs(robot: Robot, geometry: pin.GeometryModel, srdf: str | os.PathLike | None = None,
                    q: np.ndarray | None = None) -> CollisionPairs:
    """The pairs of the robot's collision geometry that are checked (module docstring); :func:`candidate_pairs`
    for every pair on different, non-adjacent bodies.

    Args:
        robot: the model; geometry: its collision geometry (:func:`collision_geometry`).
        srdf: an SRDF file whose ``<disable_collisions>`` are left out; None: the SRDF beside the model, if any.
        q: the reference configuration (nq,) whose colliding pairs are disabled when there is no SRDF (None: the
            robot's neutral configuration).

    Raises:
        ModelCheckError: the SRDF cannot be read.
        LinkNotFound: the SRDF names a link the model does not have.

    Warns:
        CollidingPairWarning: pairs in collision at the reference configuration were disabled.
    """
    every = candidate_pairs(robot, geometry)
    path = Path(srdf) if srdf is not None else srdf_beside(robot)
    if path is None:
        return without_colliding(robot, geometry, every, robot.neutral() if q is None else q) if every.links else every
    off = {frozenset(pair) for pair in read_srdf(path, robot.frame_names)}
    kept = [(int(a), int(b)) for (a, b), links in zip(every.pairs, every.links) if frozenset(links) not in off]
    srdf_disabled = {links: SRDF for links in every.links if frozenset(links) in off}
    return pair_set(robot, geometry, kept, {**every.disabled, **srdf_disabled})


def without_colliding(robot: Robot, geometry: pin.GeometryModel, pairs: CollisionPairs,
                      q: np.ndarray) -> CollisionPairs:
    """``pairs`` without the link pairs in collision (signed distance <= 0) at ``q``, with a warning."""
    import warnings

    from ..robot.configuration import Configuration
    from .distances import PairDistances

    distance = PairDistances(robot.model, geometry, pairs.pairs).evaluate(Configuration(robot, q)).distance
    colliding = {pairs.links[i] for i in np.flatnonzero(distance <= 0)}
    if not colliding:
        return pairs
    keep = [i for i, links in enumerate(pairs.links) if links not in colliding]
    names = ", ".join(f"{a}-{b}" for a, b in sorted(colliding))
    warnings.warn(f"{robot.source}: no SRDF says which link pairs to check; {len(colliding)} pair(s) in collision "
                  f"at the reference configuration are not checked: {names} (an SRDF <stem>.srdf beside the model "
                  f"with <disable_collisions> says it explicitly)", CollidingPairWarning, stacklevel=3)
    return pair_set(robot, geometry, [tuple(pairs.pairs[i]) for i in keep],
                    {**pairs.disabled, **{links: COLLIDING for links in colliding}})


# ------------------------------------------------------------------ SRDF
def srdf_beside(robot: Robot) -> Path | None:
    """The SRDF of the model file: ``<stem>.srdf`` beside it or in a sibling ``srdf/`` folder (stem without
    ``.urdf``/``.xacro``), None when there is none (or the model came as text)."""
    source = Path(robot.source)
    if not source.is_file():
        return None
    stem = source.name
    for suffix in (".xacro", ".urdf"):
        stem = stem.removesuffix(suffix)
    for candidate in (source.parent / f"{stem}.srdf", source.parent.parent / "srdf" / f"{stem}.srdf"):
        if candidate.is_file():
            return candidate
    return None


def read_srdf(path: str | os.PathLike, links: Sequence[str]) -> list[tuple[str, str]]:
    """The ``<disable_collisions link1= link2= />`` of an SRDF, read as untrusted data.

    At most :data:`MAX_SRDF_BYTES` (:func:`uvms.model.resources.read_file`), and a file that declares an XML
    entity is refused unparsed (an entity can expand to gigabytes), as a ``package.xml``
    (:func:`uvms.model.packages.package_name`).

    Args:
        path: the SRDF; links: the model's frame names (each link of an entry must be one).

    Raises:
        ModelCheckError: unreadable, too large, an entity, not XML, or an entry without both links.
        LinkNotFound: an entry names a link the model does not have (the message lists close names).
    """
    try:
        data = read_file(path, "SRDF", MAX_SRDF_BYTES, ModelCheckError)
        if b"<!ENTITY" in data:
            raise ModelCheckError(f"{path}: declares an XML entity, which an SRDF has no use for")
        root = ET.fromstring(data)
    except ET.ParseError as exc:
        raise ModelCheckError(f"{path}: the SRDF is not well-formed XML ({exc})") from None
    except UVMSError as exc:
        raise ModelCheckError(str(exc)) from None
    entries = []
    for element in root.iter("disable_collisions"):
        pair = (element.get("link1"), element.get("link2"))
        for name in pair:
            if name is None:
                raise ModelCheckError(f"{path}: a <disable_collisions> needs link1 and link2, got "
                                      f"{dict(element.attrib)}")
            if name not in links:
                raise LinkNotFound(name, links, where=f"{path}: <disable_collisions>")
        entries.append(pair)
    return entries
