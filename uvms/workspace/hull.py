"""The vehicle's own solids (box, cylinder, sphere from the URDF), to cut out of a workspace."""

from __future__ import annotations

import warnings
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..errors import WorkspaceInputError
from ..robot.robot import Robot
from .voxels import check_points

HULL_KINDS = ("box", "cylinder", "sphere")


@dataclass(frozen=True)
class HullShape:
    """A solid of the vehicle, in the vehicle frame (the frame of `BatchKinematics` points without a base pose).

    Attributes:
        link: the URDF link it belongs to.
        kind: "box", "cylinder" (axis along its local z) or "sphere".
        rotation: its axes in the vehicle frame (3, 3).
        centre: its centre in the vehicle frame (3,) [m].
        size: box edges (3,), cylinder (radius, length) or sphere (radius,) [m].
    """

    link: str
    kind: str
    rotation: np.ndarray
    centre: np.ndarray
    size: np.ndarray

    def __post_init__(self) -> None:
        sizes = {"box": 3, "cylinder": 2, "sphere": 1}
        if self.kind not in sizes:
            raise WorkspaceInputError(f"hull shape kind must be one of {', '.join(HULL_KINDS)}, got {self.kind!r}")
        size = np.asarray(self.size, dtype=float)
        if size.shape != (sizes[self.kind],) or not np.all(np.isfinite(size)) or np.any(size <= 0):
            raise WorkspaceInputError(f"a {self.kind} of link {self.link!r} needs {sizes[self.kind]} positive "
                                      f"size(s) [m], got {self.size!r}")

    def contains(self, points: np.ndarray) -> np.ndarray:
        """Which points (N, 3) [m] lie inside or on the solid: (N,) bool."""
        local = (check_points(points) - self.centre) @ self.rotation
        size = np.asarray(self.size, dtype=float)
        if self.kind == "box":
            return np.all(np.abs(local) <= 0.5 * size, axis=1)
        if self.kind == "cylinder":
            return (local[:, 0] ** 2 + local[:, 1] ** 2 <= size[0] ** 2) & (np.abs(local[:, 2]) <= 0.5 * size[1])
        return np.einsum("ij,ij->i", local, local) <= size[0] ** 2

    @property
    def volume(self) -> float:
        """Volume of the solid [m^3]."""
        size = np.asarray(self.size, dtype=float)
        if self.kind == "box":
            return float(np.prod(size))
        if self.kind == "cylinder":
            return float(np.pi * size[0] ** 2 * size[1])
        return float(4.0 / 3.0 * np.pi * size[0] ** 3)

    def outline(self) -> np.ndarray:
        """A polyline (K, 3) [m] of the solid's edges in the vehicle frame, NaN rows between pieces (for figures)."""
        size = np.asarray(self.size, dtype=float)
        gap = np.full((1, 3), np.nan)
        if self.kind == "box":
            corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * 0.5 * size
            edges = [(0, 1), (2, 3), (4, 5), (6, 7), (0, 2), (1, 3), (4, 6), (5, 7), (0, 4), (1, 5), (2, 6), (3, 7)]
            pieces = [corners[list(edge)] for edge in edges]
        else:
            angle = np.linspace(0.0, 2.0 * np.pi, 49)
            circle = np.column_stack([np.cos(angle), np.sin(angle), np.zeros_like(angle)]) * size[0]
            if self.kind == "cylinder":
                half = np.array([0.0, 0.0, 0.5 * size[1]])
                pieces = [circle + half, circle - half] + [np.array([p + half, p - half]) for p in circle[:-1:12]]
            else:
                swap = [[0, 2, 1], [2, 1, 0]]
                pieces = [circle, circle[:, swap[0]], circle[:, swap[1]]]
        local = np.vstack([row for piece in pieces for row in (piece, gap)])
        return local @ self.rotation.T + self.centre


def vehicle_links(robot: Robot) -> list[str]:
    """Links rigidly attached to the vehicle joint (the root links for a fixed base), vehicle link first."""
    root = 1 if robot.base_type != "fixed" else 0
    return [frame.name for frame in robot.model.frames
            if frame.type == pin.FrameType.BODY and frame.parentJoint == root]


def hull_shapes(robot: Robot, links: Sequence[str] | None = None, element: str = "auto") -> list[HullShape]:
    """The vehicle's solids (box, cylinder, sphere) read from the model's URDF, in the vehicle frame.

    Args:
        robot: a Robot loaded from URDF/xacro (``robot.urdf`` is its text).
        links: links whose geometry makes the hull; default: the vehicle link (the
            link of the vehicle joint; the root link for a fixed base). Each must be
            rigidly attached to the vehicle (see `vehicle_links`).
        element: "collision", "visual", or "auto" (collision geometry, else visual).

    Returns:
        The solids; meshes are skipped with a warning.

    Raises:
        WorkspaceInputError: no URDF text, a link not on the vehicle, bad ``element``, no usable solid.
    """
    if element not in ("auto", "collision", "visual"):
        raise WorkspaceInputError(f"element must be 'auto', 'collision' or 'visual', got {element!r}")
    if robot.urdf is None:
        raise WorkspaceInputError(f"{robot.name!r} has no URDF text (a composed model), so its hull cannot be read; "
                                  f"pass HullShape objects instead")
    attached = vehicle_links(robot)
    links = list(links) if links is not None else attached[:1]
    unknown = [name for name in links if name not in attached]
    if unknown or not links:
        raise WorkspaceInputError(f"hull links must be rigidly attached to the vehicle; got {unknown or links}, "
                                  f"valid: {', '.join(attached)}")
    elements = {link.get("name"): link for link in robot.urdf_root.iter("link")}
    kinds = ("collision", "visual") if element == "auto" else (element,)
    for kind in kinds:
        shapes = []
        for name in links:
            placement = robot.model.frames[robot.model.getFrameId(name, pin.FrameType.BODY)].placement
            for item in elements[name].findall(kind):
                shape = _urdf_shape(name, item, placement)
                if shape is not None:
                    shapes.append(shape)
        if shapes:
            return shapes
    raise WorkspaceInputError(f"no box, cylinder or sphere {' or '.join(kinds)} geometry on link(s) "
                              f"{', '.join(links)} of {robot.name!r}; hull removal needs one")


def _urdf_shape(link: str, item: ET.Element, placement: pin.SE3) -> HullShape | None:
    """The solid of one URDF <collision>/<visual> element, in the frame of the vehicle joint."""
    def numbers(element: ET.Element | None, name: str, default: str) -> np.ndarray:
        text = element.get(name, default) if element is not None else default
        try:
            return np.array([float(word) for word in text.split()])
        except ValueError:
            raise WorkspaceInputError(f"hull of link {link!r}: {name}={text!r} is not a list of numbers") from None

    origin = item.find("origin")
    xyz, rpy = numbers(origin, "xyz", "0 0 0"), numbers(origin, "rpy", "0 0 0")
    if xyz.shape != (3,) or rpy.shape != (3,):
        raise WorkspaceInputError(f"hull of link {link!r}: an origin needs 3 numbers in xyz and in rpy")
    pose = placement * pin.SE3(pin.rpy.rpyToMatrix(*rpy), xyz)
    geometry = item.find("geometry")
    solid = next(iter(geometry), None) if geometry is not None else None
    if solid is None:
        return None
    if solid.tag == "box":
        size = numbers(solid, "size", "")
    elif solid.tag == "cylinder":
        size = np.concatenate([numbers(solid, "radius", "nan"), numbers(solid, "length", "nan")])
    elif solid.tag == "sphere":
        size = numbers(solid, "radius", "nan")
    else:
        warnings.warn(f"hull of link {link!r}: a <{solid.tag}> is not used (only box, cylinder, sphere)", stacklevel=3)
        return None
    return HullShape(link, solid.tag, np.array(pose.rotation), np.array(pose.translation), size)


def outside_hull(points: np.ndarray, hull: HullShape | Sequence[HullShape]) -> np.ndarray:
    """Which points (N, 3) [m], in the vehicle frame, lie outside every solid of the hull: (N,) bool."""
    shapes = [hull] if isinstance(hull, HullShape) else list(hull)
    points = check_points(points)
    inside = np.zeros(points.shape[0], dtype=bool)
    for shape in shapes:
        inside |= shape.contains(points)
    return ~inside

