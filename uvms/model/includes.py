"""The static includes of a xacro file, read before xacro runs (the loader's arg check and ``--watch``).

One walk, bounded: each file read once through :func:`uvms.model.resources.read_file` (regular files only,
a size cap), within caps on files, inclusions, depth, bytes and time, so a stranger's xacro cannot make the
parent process hang or explode before the sandbox even starts.
"""

from __future__ import annotations

import os
import re
import time
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import UVMSError, XacroError
from .checks import MAX_URDF_BYTES
from .resources import read_file

#: Caps of the walk through a xacro's static includes (the arg check and ``--watch`` read them before xacro
#: runs): distinct files, inclusions counted at each use (xacro expands a file included twice twice, so 40 files
#: each including the next twice are 2**40 inclusions), nesting, bytes of all the files, and seconds.
MAX_INCLUDE_FILES = 1_000
MAX_INCLUDE_USES = 10_000
MAX_INCLUDE_DEPTH = 100
MAX_INCLUDE_SECONDS = 10.0
#: The namespaces xacro files declare for the ``xacro:`` prefix (ROS's wiki moved between these addresses; xacro
#: itself reads the prefix, not the address, so any namespace bound to ``xacro`` is read too: :func:`xacro_namespaces`).
XACRO_NAMESPACES = tuple(f"{scheme}://{host}ros.org/wiki/xacro" for scheme in ("http", "https")
                         for host in ("www.", ""))


@dataclass
class XacroWalk:
    """What a xacro file and its static includes declare, each file read once (see :func:`walk_xacro`).

    Attributes:
        files: every file reached (resolved), the given one first; an include that does not exist yet too.
        args: {name: default text or None} of the ``<xacro:arg>`` of all the files (a file's own before those
            it includes, earlier includes first); None when that cannot be known here (a file that does not
            parse or exist, an include whose name is computed or a glob, an include cycle): xacro reports it.
        problem: why the walk stopped (a cap reached, an include that is not a readable regular file), else None.
    """

    files: list[Path] = field(default_factory=list)
    args: dict[str, str | None] | None = field(default_factory=dict)
    problem: UVMSError | None = None


def parse_xacro(data: bytes) -> tuple[ET.Element, set[str]]:
    """The root element of a xacro text and the namespaces its ``xacro:`` prefix stands for.

    xacro recognises its tags by the ``xacro:`` prefix whatever address the file binds it to
    (``http://www.ros.org/wiki/xacro``, ``http://ros.org/wiki/xacro``, their https forms...), so every
    namespace bound to that prefix counts, with :data:`XACRO_NAMESPACES` always.

    Raises:
        xml.etree.ElementTree.ParseError: the text is not well-formed XML.
    """
    namespaces = set(XACRO_NAMESPACES)
    parser = ET.XMLPullParser(events=("start-ns",))
    parser.feed(data)
    parser.close()
    namespaces.update(uri for _, (prefix, uri) in parser.read_events() if prefix == "xacro")
    return ET.fromstring(data), namespaces


def xacro_elements(root: ET.Element, namespaces: set[str], tag: str) -> list[ET.Element]:
    """The elements ``xacro:<tag>`` under ``root`` (itself included), in document order, in any xacro namespace."""
    wanted = {f"{{{uri}}}{tag}" for uri in namespaces}
    return [element for element in root.iter() if element.tag in wanted]


#: An include named through a ROS package: ``$(find pkg)/rest`` (nothing else computed in it).
FIND_INCLUDE = re.compile(r"\$\(find ([A-Za-z0-9_.\-]+)\)(/[^$*?\[]*)")


def include_file(name: str, folder: Path, packages: Mapping[str, Path]) -> Path | None:
    """The file an include names: relative to the including file's folder, as xacro does, or ``$(find pkg)/...``
    through the package index; None when the name is computed otherwise (or names a package not indexed)."""
    found = FIND_INCLUDE.fullmatch(name)
    if found is not None:
        package = packages.get(found.group(1))
        return None if package is None else Path(package) / found.group(2).lstrip("/")
    return None if any(mark in name for mark in "$*?[") else folder / name


def walk_xacro(path: str | os.PathLike, packages: Mapping[str, Path] | None = None) -> XacroWalk:
    """The files a xacro includes statically, recursively, and the args they declare; it never runs xacro.

    An include named ``$(find pkg)/...`` is followed through the package index ``packages`` ({name: folder},
    :func:`uvms.model.packages.package_index`), which the loader and ``--watch`` give.

    The one reading of a xacro's includes (the loader's arg check and ``--watch``): each file is read once
    (:func:`read_file`: regular files only, at most ``MAX_URDF_BYTES``), within ``MAX_INCLUDE_FILES`` files,
    ``MAX_INCLUDE_USES`` inclusions, ``MAX_INCLUDE_DEPTH`` levels, ``MAX_URDF_BYTES`` in all and
    ``MAX_INCLUDE_SECONDS``. Reaching one stops the walk with ``problem`` set (what was found so far is kept).
    """
    walk = XacroWalk()
    done: dict[str, tuple[dict[str, str | None], int]] = {}  # resolved file -> (its args, its inclusions)
    open_files: set[str] = set()
    budget = {"bytes": MAX_URDF_BYTES, "deadline": time.monotonic() + MAX_INCLUDE_SECONDS}

    def stop(message: str) -> XacroError:
        return XacroError(f"{path}: {message}")

    def visit(file: Path, depth: int) -> tuple[dict[str, str | None], int]:
        key = os.path.realpath(file)
        if key in done:
            return done[key]
        if key in open_files or not os.path.lexists(file):  # a cycle, or a missing file: xacro reports it
            walk.args = None
            if key not in open_files and Path(key) not in walk.files:
                walk.files.append(Path(key))
            return {}, 1
        if len(done) + len(open_files) >= MAX_INCLUDE_FILES or depth > MAX_INCLUDE_DEPTH:
            raise stop(f"the xacro includes more than {MAX_INCLUDE_FILES} files or nests includes more than "
                       f"{MAX_INCLUDE_DEPTH} deep; a model includes a few dozen")
        if time.monotonic() > budget["deadline"]:
            raise stop(f"reading the xacro's includes took more than {MAX_INCLUDE_SECONDS:g} s; a model takes "
                       "milliseconds")
        if os.path.isfile(key):
            walk.files.append(Path(key))
        data = read_file(file, "xacro include" if depth else "xacro", MAX_URDF_BYTES, XacroError)
        budget["bytes"] -= len(data)
        if budget["bytes"] < 0:
            raise stop(f"the xacro and its includes hold more than {MAX_URDF_BYTES >> 20} MiB; at most that is "
                       "accepted")
        try:
            root, namespaces = parse_xacro(data)
        except ET.ParseError:
            walk.args = None  # xacro reports the real problem
            done[key] = ({}, 1)
            return done[key]
        open_files.add(key)
        args = {element.get("name"): element.get("default") for element in xacro_elements(root, namespaces, "arg")
                if element.get("name")}
        uses = 1
        for include in xacro_elements(root, namespaces, "include"):
            target = include_file(include.get("filename", ""), file.parent, packages or {})
            if target is None:  # computed, a glob or an unknown package: xacro knows
                walk.args = None
                continue
            included, count = visit(target, depth + 1)
            args, uses = {**included, **args}, uses + count
            if uses > MAX_INCLUDE_USES:
                raise stop(f"the xacro's includes expand to more than {MAX_INCLUDE_USES} inclusions (files "
                           "included again and again through nested includes); a model has a few dozen")
        open_files.discard(key)
        done[key] = (args, uses)
        return done[key]

    try:
        args, _ = visit(Path(path), 0)
    except XacroError as exc:
        walk.args, walk.problem = None, exc
    else:
        walk.args = None if walk.args is None else args
    return walk
