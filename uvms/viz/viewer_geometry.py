"""Geometry of the browser viewer: the URDF visuals with their mesh URIs resolved, or a stick skeleton.

The geometry comes from the model's URDF ``<visual>`` elements (mesh URIs resolved as
:func:`uvms.load` does: ``package://`` through the packages the robot was loaded with, ``robot.packages``
(:mod:`uvms.model.packages`); meshes that cannot be found are left out). A mesh is a stranger's file too: only
the formats of :data:`MESH_FORMATS`, at most :data:`MAX_MESH_BYTES` each, and never a compressed archive
(a ``.zae`` or a zip under any name: a 4 MB zip inflates to gigabytes) are loaded; a refused mesh is left
out with a warning that names it and the rule (:func:`mesh_refusal`), checked before any loader opens it.
A model without visual geometry is shown as a skeleton: a cylinder per arm link (parent joint origin ->
joint origin), a sphere per joint, and the end effectors in orange.
"""

from __future__ import annotations

import warnings
import zipfile
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin

from ..errors import GeometryWarning, MissingMeshWarning
from ..model import resources
from ..robot.robot import Robot

SKELETON_COLOUR = np.array([0.35, 0.35, 0.4, 1.0])
EE_COLOUR = np.array([1.0, 0.5, 0.05, 1.0])
#: The mesh formats the viewer loads (suffix, any case): plain files that Pinocchio's loader (assimp) and
#: trimesh read in memory proportional to their size. Archives (``.zae``, ``.zip``) and the rest are left out.
MESH_FORMATS = (".stl", ".dae", ".obj", ".ply")
#: The largest mesh file loaded [bytes]: 64 MiB (example-robot-data's largest mesh is a 28 MiB .dae).
MAX_MESH_BYTES = 64 << 20
#: Leading bytes of compressed containers (zip, gzip), refused whatever the file's suffix.
ARCHIVE_MAGIC = (b"PK\x03\x04", b"PK\x05\x06", b"\x1f\x8b")


def mesh_refusal(path: Path) -> str | None:
    """Why the viewer does not load the mesh file ``path`` (None: it may).

    The checks read the file's size and first bytes only: a suffix outside :data:`MESH_FORMATS`, more than
    :data:`MAX_MESH_BYTES` on disk, or a compressed archive (assimp and pycollada open a zip as a Collada
    ``.zae`` whatever its name, inflating it whole).
    """
    formats = ", ".join(MESH_FORMATS)
    if path.suffix.lower() not in MESH_FORMATS:
        return f"format {path.suffix or '(no suffix)'!r} is not loaded; the viewer loads {formats} meshes"
    try:
        size = path.stat().st_size
        with open(path, "rb") as handle:
            head = handle.read(4)
        archive = head.startswith(ARCHIVE_MAGIC) or zipfile.is_zipfile(path)
    except OSError as exc:
        return f"cannot be read ({exc.strerror or exc})"
    if size > MAX_MESH_BYTES:
        return f"{size / 2**20:.1f} MiB on disk; the viewer loads meshes of at most {MAX_MESH_BYTES >> 20} MiB"
    if archive:
        return f"a compressed archive (zip/gzip); the viewer loads uncompressed {formats} meshes only"
    return None


def resolved_urdf(robot: Robot) -> tuple[str, list[str]]:
    """The robot's URDF text with every mesh URI made an absolute path (``package://`` through ``robot.packages``);
    visuals whose mesh is missing removed.

    A visual or collision whose mesh :func:`mesh_refusal` refuses is removed too, with a warning.

    Returns:
        (URDF text, the mesh URIs that could not be found).

    Warns:
        GeometryWarning: per refused mesh, its file and the rule it breaks (the rest of the model is shown).
    """
    root = ET.fromstring(robot.urdf)  # a copy of its own: visuals are edited below
    source = Path(robot.source)
    base_dir = source.parent if source.is_file() else None
    missing: list[str] = []
    refused: dict[Path, str | None] = {}
    for link in root.iter("link"):
        for kind in ("visual", "collision"):
            for element in list(link.findall(kind)):
                mesh = element.find("geometry/mesh")
                if mesh is None:
                    continue
                uri = mesh.get("filename", "")
                path = resources.resolve_uri(uri, base_dir, robot.packages)
                if path is None:
                    missing.append(uri)
                    link.remove(element)
                    continue
                path = path.resolve()
                if path not in refused:
                    refused[path] = mesh_refusal(path)
                if refused[path] is None:
                    mesh.set("filename", str(path))
                else:
                    link.remove(element)
    for path, reason in refused.items():
        if reason is not None:
            warnings.warn(f"{robot.source}: mesh {str(path)!r} not shown: {reason}", GeometryWarning, stacklevel=2)
    return ET.tostring(root, encoding="unicode"), sorted(set(missing))


def _align_z(direction: np.ndarray) -> np.ndarray:
    """A rotation whose z axis is the unit vector ``direction``."""
    return pin.Quaternion.FromTwoVectors(np.array([0.0, 0.0, 1.0]), direction).toRotationMatrix()


def skeleton_geometry(robot: Robot, radius: float | None = None) -> pin.GeometryModel:
    """Stick geometry of any model: a cylinder per arm link, a sphere per joint, end effectors in orange.

    Args:
        robot: the robot.
        radius: link radius [m]; default 4 % of the longest link (at least 5 mm).
    """
    import coal  # shipped with the pin wheel

    model = robot.model
    links = [(j, model.jointPlacements[j].translation) for j in range(1, model.njoints) if model.parents[j] > 0]
    ee = [(robot.frame_id(name), name) for name in robot.ee_frames]
    lengths = [np.linalg.norm(d) for _, d in links] + [np.linalg.norm(model.frames[f].placement.translation)
                                                        for f, _ in ee]
    if radius is None:
        radius = max(0.04 * max(lengths, default=0.0), 0.005)
    geometry = pin.GeometryModel()

    def add(name: str, joint: int, placement: pin.SE3, shape, colour: np.ndarray) -> None:
        frame = model.getFrameId(model.names[joint], pin.FrameType.JOINT) if joint > 0 else 0
        item = pin.GeometryObject(name, joint, frame, placement, shape)
        item.meshColor = colour
        geometry.addGeometryObject(item)

    def segment(name: str, joint: int, start: np.ndarray, end: np.ndarray, colour: np.ndarray) -> None:
        offset = end - start
        length = float(np.linalg.norm(offset))
        if length > 1e-6:
            add(name, joint, pin.SE3(_align_z(offset / length), (start + end) / 2),
                coal.Cylinder(radius, length), colour)

    for joint in range(1, model.njoints):
        add(f"skeleton/joint_{model.names[joint]}", joint, pin.SE3.Identity(), coal.Sphere(1.6 * radius),
            SKELETON_COLOUR)
    for joint, offset in links:
        segment(f"skeleton/link_{model.names[joint]}", model.parents[joint], np.zeros(3), offset, SKELETON_COLOUR)
    for frame_id, name in ee:
        frame = model.frames[frame_id]
        placement = frame.placement
        segment(f"skeleton/ee_{name}", frame.parentJoint, np.zeros(3), placement.translation, EE_COLOUR)
        add(f"skeleton/ee_tip_{name}", frame.parentJoint, placement, coal.Sphere(1.8 * radius), EE_COLOUR)
    return geometry


def geometry_models(robot: Robot, skeleton: bool | None = None) -> tuple[pin.GeometryModel, pin.GeometryModel]:
    """The (visual, collision) geometry models the viewer shows.

    Args:
        robot: the robot.
        skeleton: add the stick geometry of :func:`skeleton_geometry`; None: only when the model
            has no visual geometry (no URDF, or a URDF without ``<visual>``).

    Returns:
        The visual model (URDF visuals, plus the skeleton) and the collision model (URDF collisions;
        hidden by the viewer unless asked).

    Warns:
        MissingMeshWarning: some meshes cannot be found (they are left out).
    """
    visual, collision = pin.GeometryModel(), pin.GeometryModel()
    if robot.urdf is not None:
        xml, missing = resolved_urdf(robot)
        if missing:
            warnings.warn(f"{robot.source}: {len(missing)} mesh file(s) not found (e.g. {missing[0]!r}); "
                          f"they are not shown", MissingMeshWarning, stacklevel=2)
        try:
            visual = pin.buildGeomFromUrdfString(robot.model, xml, pin.GeometryType.VISUAL)
            collision = pin.buildGeomFromUrdfString(robot.model, xml, pin.GeometryType.COLLISION)
        except (RuntimeError, ValueError) as exc:
            warnings.warn(f"{robot.source}: Pinocchio cannot read the geometry ({' '.join(str(exc).split())}); "
                          f"showing the skeleton", GeometryWarning, stacklevel=2)
            visual, collision = pin.GeometryModel(), pin.GeometryModel()
    if skeleton or (skeleton is None and visual.ngeoms == 0):
        for item in skeleton_geometry(robot).geometryObjects:
            visual.addGeometryObject(item)
    return visual, collision
