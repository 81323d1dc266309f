"""Mesh files of a model: which ones uvms loads, and the URDF with every mesh URI made an absolute path.

The viewer (:mod:`uvms.viz.viewer.geometry`) and the collision geometry (:mod:`uvms.model.collision`) read the
meshes of a URDF through :func:`resolved_urdf`: mesh URIs resolved as :func:`uvms.load` does (``package://``
through the packages the robot was loaded with, ``robot.packages``, :mod:`uvms.model.packages`). A mesh is a
stranger's file too: only regular files of the formats of :data:`MESH_FORMATS`, at most :data:`MAX_MESH_BYTES` each,
and never a compressed archive (a ``.zae`` or a zip under any name: a 4 MB zip inflates to gigabytes) are loaded
(:func:`mesh_refusal`, checked before any loader opens the file). The files a mesh names for its loaders to open
next (an OBJ's ``mtllib`` materials and their texture maps, a PLY's ``TextureFile``, a Collada ``<init_from>``
image) are checked the same way (:func:`named_file_refusal`): assimp (coal, Pinocchio) and trimesh (the viewer)
open them by name, and a FIFO there blocks the loader where neither Ctrl-C nor SIGTERM reaches it.
"""

from __future__ import annotations

import io
import os
import re
import stat
import urllib.parse
import warnings
import xml.etree.ElementTree as ET
import zipfile
from collections.abc import Mapping, Sequence
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


#: The most file names a mesh may give its loaders (materials, textures); a mesh naming more is refused.
MAX_NAMED_FILES = 64
#: Where each format names further files: the rest of the line after the keyword (an OBJ's ``mtllib``, a
#: material's texture maps, a PLY header's ``comment TextureFile``) or a Collada image's ``<init_from>``. Matched
#: anywhere, as trimesh does (it takes the first ``mtllib`` even inside a comment), so a superset is checked.
NAMED_FILES = {
    ".obj": re.compile(rb"mtllib([^\r\n]*)"),
    ".mtl": re.compile(rb"(?im)^[ \t]*(?:map_\w+|bump|disp|decal|refl|norm)\b([^\r\n]*)"),
    ".ply": re.compile(rb"(?i)texturefile([^\r\n]*)"),
    ".dae": re.compile(rb"<init_from>([^<]*)</init_from>"),
}


def mesh_refusal(path: Path) -> str | None:
    """Why uvms does not load the mesh file ``path`` (None: it may).

    A suffix outside :data:`MESH_FORMATS`; not a regular file (a FIFO, ``/dev/zero``: checked before it is opened)
    or more than :data:`MAX_MESH_BYTES` (read by :func:`uvms.model.resources.read_file`); a compressed archive
    (assimp and pycollada open a zip as a Collada ``.zae`` whatever its name, inflating it whole); or a file it
    names that :func:`named_file_refusal` refuses.
    """
    formats = ", ".join(MESH_FORMATS)
    if path.suffix.lower() not in MESH_FORMATS:
        return f"format {path.suffix or '(no suffix)'!r} is not loaded; uvms loads {formats} meshes"
    try:
        size = os.stat(path).st_size
        data = resources.read_file(path, "mesh", MAX_MESH_BYTES, ModelCheckError)  # a regular file, bounded
    except OSError as exc:
        return f"cannot be read ({exc.strerror or exc})"
    except ModelCheckError as exc:
        if size > MAX_MESH_BYTES:
            return f"{size / 2**20:.1f} MiB on disk; uvms loads meshes of at most {MAX_MESH_BYTES >> 20} MiB"
        return str(exc).removeprefix(f"{path}: ")
    if data.startswith(ARCHIVE_MAGIC) or zipfile.is_zipfile(io.BytesIO(data)):
        return f"a compressed archive (zip/gzip); uvms loads uncompressed {formats} meshes only"
    return named_file_refusal(path, data)


def named_file_refusal(path: Path, data: bytes) -> str | None:
    """Why a mesh ``path`` (its bytes ``data``) is refused for a file its loaders would open next (None: none is).

    Every file a name of :data:`NAMED_FILES` may lead to is checked, as assimp and trimesh look it up: the name
    beside the mesh, without a leading ``/``, its last component, each word of it, and an OBJ's ``<stem>.mtl``
    (assimp's fallback). One that exists must be a regular file (or a folder, which a loader cannot read and
    skips) of at most :data:`MAX_MESH_BYTES`; a material file is read and its texture maps checked in turn.
    A missing one is left to the loader (it loads the geometry without it).
    """
    pending, names, checked = [(path, data)], set(), set()
    while pending:
        source, text = pending.pop()
        pattern = NAMED_FILES.get(source.suffix.lower())
        found = [os.fsdecode(match.group(1)) for match in pattern.finditer(text)] if pattern else []
        names.update(found)
        if len(names) > MAX_NAMED_FILES:
            return f"it names more than {MAX_NAMED_FILES} files (materials, textures) for its loader to open"
        candidates = [path.with_suffix(".mtl")] if source.suffix.lower() == ".obj" else []
        for name in found:
            candidates += named_candidates(path.parent, name) + named_candidates(source.parent, name)
        for candidate in dict.fromkeys(candidate for candidate in candidates if candidate not in checked):
            checked.add(candidate)
            try:
                info = os.stat(candidate)
            except (OSError, ValueError):  # missing or unreachable: the loader cannot open it either
                continue
            if stat.S_ISDIR(info.st_mode):  # a loader's open fails at once
                continue
            if not stat.S_ISREG(info.st_mode):
                return f"it names {str(candidate)!r}, {resources.file_kind(info)}, for its loader to open next"
            if info.st_size > MAX_MESH_BYTES:
                return (f"it names {str(candidate)!r} ({info.st_size / 2**20:.1f} MiB) for its loader to open next; "
                        f"at most {MAX_MESH_BYTES >> 20} MiB")
            if candidate.suffix.lower() == ".mtl":
                try:
                    pending.append((candidate, resources.read_file(candidate, "material", MAX_MESH_BYTES,
                                                                   ModelCheckError)))
                except ModelCheckError as exc:
                    return f"it names a material file that cannot be read ({exc})"
    return None


def named_candidates(folder: Path, name: str) -> list[Path]:
    """The files a name written in a mesh may open, looked up as assimp and trimesh do (see
    :func:`named_file_refusal`); a Collada ``file://`` URI and %-escapes decoded too."""
    name = name.strip()
    names = {name, name.lstrip("/"), os.path.basename(name), *name.split()}
    for uri in list(names):
        decoded = urllib.parse.unquote(uri.removeprefix("file://"))
        names |= {decoded, decoded.lstrip("/"), os.path.basename(decoded)}
    return [folder / item for item in sorted(names) if item.strip()]


#: Scene formats a URDF of a public package may name in a ``<mesh>`` that are not meshes (UWSim's OpenSceneGraph).
SCENE_FORMATS = {".osg": "OpenSceneGraph (UWSim)", ".osgb": "OpenSceneGraph (UWSim)", ".osgt": "OpenSceneGraph (UWSim)",
                 ".ive": "OpenSceneGraph (UWSim)"}
#: How many causes a note on meshes that cannot be found lists (each with a count and an example).
LISTED_CAUSES = 4


def missing_mesh_cause(uri: str, base_dir: Path | None, packages: Mapping[str, Path], model: str = "") -> str:
    """Why the mesh ``uri`` that :func:`uvms.model.resources.resolve_uri` could not find is not shown, in words a
    user can act on: a format uvms does not read (whatever the path), a ``package://`` of a package the index
    lacks (where it looked, :func:`uvms.model.packages.package_search`), a package found without that file, or a
    path with no file. Several URIs of one cause give the same text (the note groups them)."""
    from .packages import package_search

    suffix = os.path.splitext(uri)[1].lower()
    if suffix not in MESH_FORMATS:
        what = (f"{suffix!r} files are {SCENE_FORMATS[suffix]} scenes, not meshes" if suffix in SCENE_FORMATS
                else f"format {suffix or '(no suffix)'!r} is not a mesh format")
        return f"{what}: uvms reads {', '.join(MESH_FORMATS)} meshes; convert them (e.g. to .stl or .dae) to show them"
    if uri.startswith("package://"):
        package = uri[len("package://"):].partition("/")[0]
        if package not in packages:
            return package_search(package, packages, model)
        return f"package {package!r} (searched at {packages[package]}) does not hold them"
    return f"no such file{f' (relative paths from {base_dir})' if base_dir is not None else ''}"


def missing_meshes_note(origin: str, missing: Sequence[str], base_dir: Path | None, packages: Mapping[str, Path],
                        model: str = "") -> str:
    """The one warning of meshes that cannot be found: their count, then per cause (:func:`missing_mesh_cause`,
    at most :data:`LISTED_CAUSES`) how many and an example."""
    causes: dict[str, list[str]] = {}
    for uri in sorted(set(missing)):  # one text for the same meshes, whoever found them missing
        causes.setdefault(missing_mesh_cause(uri, base_dir, packages, model), []).append(uri)
    parts = [f"{len(uris)} ({'e.g. ' if len(uris) > 1 else ''}{uris[0]!r}): {cause}"
             for cause, uris in list(causes.items())[:LISTED_CAUSES]]
    more = f"; and {len(causes) - LISTED_CAUSES} more causes" if len(causes) > LISTED_CAUSES else ""
    return (f"{origin}: {len(set(missing))} mesh file(s) not found, not shown (kinematics is unaffected): "
            f"{'; '.join(parts)}{more}")


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
                        cause = missing_mesh_cause(uri, base_dir, robot.packages, robot.source if base_dir else "")
                        raise ModelCheckError(f"{robot.source}: link {link.get('name')!r}: the {kind} mesh {uri!r} "
                                              f"cannot be found: {cause}")
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
