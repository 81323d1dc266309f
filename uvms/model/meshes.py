"""Mesh files of a model: which ones uvms loads, and the URDF with every mesh URI made an absolute path.

The viewer (:mod:`uvms.viz.viewer_geometry`) and the collision geometry (:mod:`uvms.model.collision`) read the
meshes of a URDF through :func:`resolved_urdf`: mesh URIs resolved as :func:`uvms.load` does (``package://``
through the packages the robot was loaded with, ``robot.packages``, :mod:`uvms.model.packages`). A mesh is a
stranger's file too: only the formats of :data:`MESH_FORMATS`, at most :data:`MAX_MESH_BYTES` each, and never a
compressed archive (a ``.zae`` or a zip under any name: a 4 MB zip inflates to gigabytes) are loaded
(:func:`mesh_refusal`, checked before any loader opens the file).
"""

from __future__ import annotations

import warnings
import zipfile
import xml.etree.ElementTree as ET
from pathlib import Path

from ..errors import GeometryWarning, ModelCheckError
from ..robot.robot import Robot
from . import resources

#: The mesh formats uvms loads (suffix, any case): plain files that Pinocchio's loader (assimp) and
#: trimesh read in memory proportional to their size. Archives (``.zae``, ``.zip``) and the rest are refused.
MESH_FORMATS = (".stl", ".dae", ".obj", ".ply")
#: The largest mesh file loaded [bytes]: 64 MiB (example-robot-data's largest mesh is a 28 MiB .dae).
MAX_MESH_BYTES = 64 << 20
#: Leading bytes of compressed containers (zip, gzip), refused whatever the file's suffix.
ARCHIVE_MAGIC = (b"PK\x03\x04", b"PK\x05\x06", b"\x1f\x8b")


def mesh_refusal(path: Path) -> str | None:
    """Why uvms does not load the mesh file ``path`` (None: it may).

    The checks read the file's size and first bytes only: a suffix outside :data:`MESH_FORMATS`, more than
    :data:`MAX_MESH_BYTES` on disk, or a compressed archive (assimp and pycollada open a zip as a Collada
    ``.zae`` whatever its name, inflating it whole).
    """
    formats = ", ".join(MESH_FORMATS)
    if path.suffix.lower() not in MESH_FORMATS:
        return f"format {path.suffix or '(no suffix)'!r} is not loaded; uvms loads {formats} meshes"
    try:
        size = path.stat().st_size
        with open(path, "rb") as handle:
            head = handle.read(4)
        archive = head.startswith(ARCHIVE_MAGIC) or zipfile.is_zipfile(path)
    except OSError as exc:
        return f"cannot be read ({exc.strerror or exc})"
    if size > MAX_MESH_BYTES:
        return f"{size / 2**20:.1f} MiB on disk; uvms loads meshes of at most {MAX_MESH_BYTES >> 20} MiB"
    if archive:
        return f"a compressed archive (zip/gzip); uvms loads uncompressed {formats} meshes only"
    return None


def resolved_urdf(robot: Robot, strict: bool = False) -> tuple[str, list[str]]:
    """The robot's URDF text with every mesh URI made an absolute path (``package://`` through ``robot.packages``).

    Args:
        robot: the robot.
        strict: the collision geometry's text: the ``<visual>`` elements are removed and a ``<collision>`` mesh
            that is missing or that :func:`mesh_refusal` refuses raises (every shape is needed); False (the
            viewer's): a ``<visual>`` or ``<collision>`` whose mesh is missing or refused is removed (a refused one
            with a warning), and the rest of the model is shown.

    Returns:
        (URDF text, the mesh URIs that could not be found).

    Raises:
        ModelCheckError: ``strict`` and a mesh is missing or refused (the message names the link, the URI and
            the rule it breaks).

    Warns:
        GeometryWarning: not ``strict``, per refused mesh, its file and the rule it breaks.
    """
    root = ET.fromstring(robot.urdf)  # a copy of its own: visuals are edited below
    source = Path(robot.source)
    base_dir = source.parent if source.is_file() else None
    missing: list[str] = []
    refused: dict[Path, str | None] = {}
    for link in root.iter("link"):
        if strict:
            for element in link.findall("visual"):
                link.remove(element)
        for kind in ("visual", "collision"):
            for element in list(link.findall(kind)):
                mesh = element.find("geometry/mesh")
                if mesh is None:
                    continue
                uri = mesh.get("filename", "")
                path = resources.resolve_uri(uri, base_dir, robot.packages)
                if path is None:
                    if strict:
                        raise ModelCheckError(f"{robot.source}: link {link.get('name')!r}: the {kind} mesh {uri!r} "
                                              f"cannot be found; give a file path relative to the model, or a "
                                              f"package:// URI of a package it was loaded with "
                                              f"({', '.join(sorted(robot.packages)) or 'none'})")
                    missing.append(uri)
                    link.remove(element)
                    continue
                path = path.resolve()
                if path not in refused:
                    refused[path] = mesh_refusal(path)
                if refused[path] is None:
                    mesh.set("filename", str(path))
                elif strict:
                    raise ModelCheckError(f"{robot.source}: link {link.get('name')!r}: the {kind} mesh "
                                          f"{str(path)!r} is refused: {refused[path]}")
                else:
                    link.remove(element)
    for path, reason in refused.items():
        if reason is not None:
            warnings.warn(f"{robot.source}: mesh {str(path)!r} not shown: {reason}", GeometryWarning, stacklevel=2)
    return ET.tostring(root, encoding="unicode"), sorted(set(missing))
