"""The shape and world placement of an obstacle given by plain parameters (a scenario's ``obstacle`` table)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pinocchio as pin

from ...errors import ModelCheckError, ObjectiveError
from ...model.collision import convex_shape
from ...model.meshes import mesh_refusal
from ...numerics.validate import finite_array
from .base import finite_number

#: Obstacle geometry -> the dimension keys it takes (every one required).
OBSTACLE_KEYS = {"box": ("size",), "sphere": ("radius",), "cylinder": ("radius", "length"),
                 "plane": ("point", "normal"), "mesh": ("mesh",)}
#: Keys of a placed obstacle (every geometry but the plane); their defaults place it at the origin, unrotated.
PLACEMENT_KEYS = ("position", "rpy")


def obstacle_shape(name: str, geometry: str, *, position: Sequence[float], rpy: Sequence[float],
                   **dimensions: object) -> tuple[object, pin.SE3]:
    """(coal shape, placement in the world) of an obstacle.

    Args:
        name: the objective's name (for messages); geometry: a key of :data:`OBSTACLE_KEYS`.
        position, rpy: the placement [m], [rad] (a plane takes neither: its point and normal place it).
        dimensions: size, radius, length, point, normal, mesh: the ones the geometry takes, the others None.

    Raises:
        ObjectiveError: an unknown geometry, a key missing or not taken, a dimension that is not finite and > 0,
            a zero normal, a placement given to a plane, a mesh file missing, refused or without a volume.
    """
    import coal  # shipped with the pin wheel

    if geometry not in OBSTACLE_KEYS:
        raise ObjectiveError(f"{name}: unknown obstacle geometry {geometry!r}; valid: {', '.join(OBSTACLE_KEYS)}")
    takes = OBSTACLE_KEYS[geometry]
    given = {key for key, value in dimensions.items() if value is not None}
    if given - set(takes) or set(takes) - given:
        raise ObjectiveError(f"{name}: a {geometry} obstacle takes {', '.join(takes)}, got "
                             f"{', '.join(sorted(given)) or 'none of them'}")
    placement = pin.SE3(pin.rpy.rpyToMatrix(*finite_array(rpy, f"{name}: rpy", (3,), error=ObjectiveError,
                                                          unit=" [rad]")),
                        finite_array(position, f"{name}: position", (3,), error=ObjectiveError, unit=" [m]"))
    if geometry == "plane":
        if not placement.isIdentity():
            raise ObjectiveError(f"{name}: a plane is placed by its point and normal; leave position and rpy out")
        point = finite_array(dimensions["point"], f"{name}: point", (3,), error=ObjectiveError, unit=" [m]")
        normal = finite_array(dimensions["normal"], f"{name}: normal", (3,), error=ObjectiveError)
        if np.linalg.norm(normal) < 1e-12:
            raise ObjectiveError(f"{name}: the plane's normal must be a non-zero vector, got {normal.tolist()}")
        normal = normal / np.linalg.norm(normal)
        return coal.Halfspace(normal, float(normal @ point)), placement  # the solid: n . x <= n . point
    if geometry == "mesh":
        return mesh_obstacle(name, Path(str(dimensions["mesh"]))), placement
    if geometry == "box":
        sides = finite_array(dimensions["size"], f"{name}: size", (3,), error=ObjectiveError, unit=" [m]")
        if np.any(sides <= 0):
            raise ObjectiveError(f"{name}: a box's size must be 3 sides > 0 [m], got {sides.tolist()}")
        return coal.Box(*sides), placement
    radius = finite_number(dimensions["radius"], f"{name}: radius [m]", positive=True)
    if geometry == "sphere":
        return coal.Sphere(radius), placement
    return coal.Cylinder(radius, finite_number(dimensions["length"], f"{name}: length [m]", positive=True)), placement


def mesh_obstacle(name: str, path: Path) -> object:
    """The convex hull of a mesh file (loaded only if :func:`uvms.model.meshes.mesh_refusal` allows it).

    Raises:
        ObjectiveError: missing, refused, unreadable, or without a volume.
    """
    import coal  # shipped with the pin wheel

    if not path.exists():  # a FIFO or a device exists and is refused below, before anything opens it
        raise ObjectiveError(f"{name}: the mesh file {str(path)!r} does not exist; give a mesh file (.stl, .dae, "
                             f".obj, .ply) inside the scenario's folder")
    reason = mesh_refusal(path)
    if reason is not None:
        raise ObjectiveError(f"{name}: the mesh file {str(path)!r} is refused: {reason}")
    try:
        loaded = coal.MeshLoader().load(str(path))
    except (RuntimeError, ValueError) as exc:
        raise ObjectiveError(f"{name}: cannot read the mesh file {str(path)!r} "
                             f"({' '.join(str(exc).split())})") from None
    try:
        return convex_shape(loaded, f"{name}: mesh {str(path)!r}")
    except ModelCheckError as exc:
        raise ObjectiveError(str(exc)) from None
