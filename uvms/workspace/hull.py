"""The vehicle's own solids (box, cylinder, sphere, and the convex hull of a mesh, from the URDF), to cut out of a
workspace."""

from __future__ import annotations

import warnings
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin

from ..errors import GeometryWarning, MissingMeshWarning, WorkspaceInputError
from ..model import resources
from ..model.meshes import mesh_refusal
from ..robot.robot import Robot
from .voxels import check_points

HULL_KINDS = ("box", "cylinder", "sphere", "convex")
#: Sizes each kind takes: box edges, cylinder (radius, length), sphere radius, a convex hull's bounding-box edges.
SIZE_COUNTS = {"box": 3, "cylinder": 2, "sphere": 1, "convex": 3}


@dataclass(frozen=True)
class HullShape:
    """A solid of the vehicle, in the vehicle frame (the frame of `BatchKinematics` points without a base pose).

    Attributes:
        link: the URDF link it belongs to.
        kind: "box", "cylinder" (axis along its local z), "sphere" or "convex" (the convex hull of ``vertices``).
        rotation: its axes in the vehicle frame (3, 3).
        centre: its centre in the vehicle frame (3,) [m].
        size: box edges (3,), cylinder (radius, length), sphere (radius,) or a convex hull's bounding-box
            edges (3,) [m] (computed from ``vertices`` when not given).
        vertices: a convex hull's points in its own frame (rotation, centre) (K, 3) [m]; None for the others.
    """

    link: str
    kind: str
    rotation: np.ndarray
    centre: np.ndarray
    size: np.ndarray | None = None
    vertices: np.ndarray | None = None
    facets: np.ndarray | None = field(default=None, init=False, repr=False)  # (F, 4): n . x + d <= 0 inside

    def __post_init__(self) -> None:
        if self.kind not in SIZE_COUNTS:
            raise WorkspaceInputError(f"hull shape kind must be one of {', '.join(HULL_KINDS)}, got {self.kind!r}")
        if self.kind == "convex":
            self._take_convex_hull()
        size = np.asarray(self.size, dtype=float)
        count = SIZE_COUNTS[self.kind]
        if size.shape != (count,) or not np.all(np.isfinite(size)) or np.any(size <= 0):
            raise WorkspaceInputError(f"a {self.kind} of link {self.link!r} needs {count} positive "
                                      f"size(s) [m], got {self.size!r}")

    def _take_convex_hull(self) -> None:
        """The facets of the convex hull of ``vertices`` (scipy's Qhull) and its bounding box as ``size``."""
        from scipy.spatial import ConvexHull, QhullError

        points = None if self.vertices is None else np.asarray(self.vertices, dtype=float)
        if points is None or points.ndim != 2 or points.shape[1] != 3 or not np.all(np.isfinite(points)):
            raise WorkspaceInputError(f"a convex hull shape of link {self.link!r} needs vertices (K, 3) [m]")
        try:
            hull = ConvexHull(points)
        except (QhullError, ValueError):
            raise WorkspaceInputError(f"the vertices of link {self.link!r} span no volume (flat or fewer than 4 "
                                      "points); a convex hull needs a solid") from None
        object.__setattr__(self, "vertices", points[hull.vertices])
        object.__setattr__(self, "facets", hull.equations)
        if self.size is None:
            object.__setattr__(self, "size", np.ptp(points, axis=0))

    def contains(self, points: np.ndarray) -> np.ndarray:
        """Which points (N, 3) [m] lie inside or on the solid: (N,) bool."""
        local = (check_points(points) - self.centre) @ self.rotation
        size = np.asarray(self.size, dtype=float)
        if self.kind == "convex":
            # inside every facet's half-space; the tolerance keeps points on a facet (rounding of Qhull's planes)
            return np.all(local @ self.facets[:, :3].T + self.facets[:, 3] <= 1e-12 * np.max(size), axis=1)
        if self.kind == "box":
            return np.all(np.abs(local) <= 0.5 * size, axis=1)
        if self.kind == "cylinder":
            return (local[:, 0] ** 2 + local[:, 1] ** 2 <= size[0] ** 2) & (np.abs(local[:, 2]) <= 0.5 * size[1])
        return np.einsum("ij,ij->i", local, local) <= size[0] ** 2

    @property
    def volume(self) -> float:
        """Volume of the solid [m^3]."""
        size = np.asarray(self.size, dtype=float)
        if self.kind == "convex":
            from scipy.spatial import ConvexHull

            return float(ConvexHull(self.vertices).volume)
        if self.kind == "box":
            return float(np.prod(size))
        if self.kind == "cylinder":
            return float(np.pi * size[0] ** 2 * size[1])
        return float(4.0 / 3.0 * np.pi * size[0] ** 3)

    def outline(self) -> np.ndarray:
        """A polyline (K, 3) [m] of the solid's edges in the vehicle frame, NaN rows between pieces (for figures)."""
        size = np.asarray(self.size, dtype=float)
        gap = np.full((1, 3), np.nan)
        if self.kind == "convex":  # the bounding box's edges: a mesh's hull has hundreds of facets
            corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * 0.5 * size
            corners += 0.5 * (self.vertices.min(axis=0) + self.vertices.max(axis=0))
            edges = [(0, 1), (2, 3), (4, 5), (6, 7), (0, 2), (1, 3), (4, 6), (5, 7), (0, 4), (1, 5), (2, 6), (3, 7)]
            pieces = [corners[list(edge)] for edge in edges]
        elif self.kind == "box":
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
    # by default every link fixed to the vehicle: a ROS vehicle often roots at a massless base_footprint and
    # carries its hull on a child link
    links = list(links) if links is not None else attached
    unknown = [name for name in links if name not in attached]
    if unknown or not links:
        raise WorkspaceInputError(f"hull links must be rigidly attached to the vehicle; got {unknown or links}, "
                                  f"valid: {', '.join(attached)}")
    elements = {link.get("name"): link for link in robot.urdf_root.findall("link")}  # not a plugin's <link>
    kinds = ("collision", "visual") if element == "auto" else (element,)
    for kind in kinds:
        shapes = []
        for name in links:
            placement = robot.model.frames[robot.model.getFrameId(name, pin.FrameType.BODY)].placement
            for item in elements[name].findall(kind):
                shape = _urdf_shape(name, item, placement, mesh_folder(robot), robot.packages)
                if shape is not None:
                    shapes.append(shape)
        if shapes:
            return shapes
    raise WorkspaceInputError(f"no box, cylinder, sphere or mesh {' or '.join(kinds)} geometry on link(s) "
                              f"{', '.join(links)} of {robot.name!r}; hull removal needs one")


def mesh_folder(robot: Robot) -> Path | None:
    """The folder relative mesh paths of the robot's URDF start from (its file's), or None for URDF text."""
    source = Path(robot.source) if robot.source else None
    return source.parent if source is not None and source.is_file() else None


def _urdf_shape(link: str, item: ET.Element, placement: pin.SE3, folder: Path | None = None,
                packages: Mapping[str, Path] | None = None) -> HullShape | None:
    """The solid of one URDF <collision>/<visual> element, in the frame of the vehicle joint (None: no solid).

    A mesh becomes the convex hull of its vertices (coal reads STL, DAE, OBJ...), with a warning when its file
    cannot be found or read.
    """
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
    elif solid.tag == "mesh":
        scale = numbers(solid, "scale", "1 1 1")
        vertices = mesh_vertices(link, solid.get("filename", ""), scale, folder, packages or {})
        if vertices is None:
            return None
        return HullShape(link, "convex", np.array(pose.rotation), np.array(pose.translation), vertices=vertices)
    else:
        warnings.warn(f"hull of link {link!r}: a <{solid.tag}> is not used (only box, cylinder, sphere, mesh)",
                      GeometryWarning, stacklevel=3)
        return None
    return HullShape(link, solid.tag, np.array(pose.rotation), np.array(pose.translation), size)


def mesh_vertices(link: str, uri: str, scale: np.ndarray, folder: Path | None,
                  packages: Mapping[str, Path]) -> np.ndarray | None:
    """The vertices (K, 3) [m] of a URDF mesh, scaled, in the mesh's frame; None (with a warning) when its file
    cannot be found (``package://`` through the robot's ``packages``), is refused
    (:func:`uvms.model.meshes.mesh_refusal`) or cannot be read."""
    import coal

    path = resources.resolve_uri(uri, folder, packages)
    if path is None or scale.shape != (3,):
        warnings.warn(f"hull of link {link!r}: mesh {uri!r} not found (or its scale is not 3 numbers); it is not "
                      "used", MissingMeshWarning, stacklevel=4)
        return None
    reason = mesh_refusal(path)
    if reason is not None:  # checked before assimp opens it or a file it names (a FIFO would block it)
        warnings.warn(f"hull of link {link!r}: mesh {str(path)!r} is refused: {reason}; it is not used",
                      GeometryWarning, stacklevel=4)
        return None
    try:
        return np.asarray(coal.MeshLoader().load(str(path), scale).vertices(), dtype=float)
    except (RuntimeError, ValueError) as exc:
        warnings.warn(f"hull of link {link!r}: mesh {path.name} cannot be read ({' '.join(str(exc).split())[:200]})"
                      "; it is not used", GeometryWarning, stacklevel=4)
        return None


def outside_hull(points: np.ndarray, hull: HullShape | Sequence[HullShape]) -> np.ndarray:
    """Which points (N, 3) [m], in the vehicle frame, lie outside every solid of the hull: (N,) bool."""
    shapes = [hull] if isinstance(hull, HullShape) else list(hull)
    points = check_points(points)
    inside = np.zeros(points.shape[0], dtype=bool)
    for shape in shapes:
        inside |= shape.contains(points)
    return ~inside

