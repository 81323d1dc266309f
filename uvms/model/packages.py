"""ROS packages without ROS: the index {package name: folder} that ``$(find pkg)`` and ``package://pkg/...`` use.

The folders searched, first in precedence first (a name found twice keeps its first folder, as ROS does):

1. the folders the user names (``uvms.load(package_path=...)``, ``--package-path DIR``, a scenario's
   ``[model] package_path``): each is a package itself (it holds ``package.xml``) or a folder searched for
   packages;
2. ``ROS_PACKAGE_PATH``: folders searched for packages, as ROS 1's rospack does;
3. ``AMENT_PREFIX_PATH``: install prefixes, ``<prefix>/share/<pkg>/package.xml`` (the package is named by its
   folder, as ament_index does);
4. the model's own workspace (:func:`model_workspace`): the ``src`` folder above a model that lies in a ROS
   package, else that package alone (a package unpacked in a downloads folder does not get the packages beside
   it: they are not its workspace, and their files are not its to read);
5. example-robot-data's installed share folder (its URDFs say ``package://example-robot-data/...``).

A search (:func:`find_packages`) stops descending at a folder holding ``package.xml``, skips hidden folders
and folders holding ``CATKIN_IGNORE``, ``COLCON_IGNORE`` or ``AMENT_IGNORE``, follows a symbolic link only to
a folder inside the searched tree (each folder once, so a link loop ends), and stops at
:data:`MAX_PACKAGE_DEPTH` levels and :data:`MAX_PACKAGE_FOLDERS` folders with a warning: a stranger's tree
cannot make it hang. A package is named by the ``<name>`` of its ``package.xml`` (read within a size cap,
no entity), else by its folder.

The trust boundary: ``$(find)`` and ``package://`` resolve only to the packages of this index, that is to
folders the user named or to the model's own tree; an untrusted xacro's sandbox may read those and nothing
else (:mod:`uvms.model.sandbox`).
"""

from __future__ import annotations

import collections
import os
import re
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from pathlib import Path

from ..errors import ModelFileNotFound, PackageSearchWarning, UVMSError
from .resources import example_robot_data_dir, read_file

#: Bounds of one search for packages: levels below the searched folder, and folders visited (a ROS
#: distribution's share folder holds about a thousand packages, one level deep).
MAX_PACKAGE_DEPTH = 16
MAX_PACKAGE_FOLDERS = 20_000
#: Levels walked up from a model file to find its workspace.
MAX_WORKSPACE_LEVELS = 8
#: The largest ``package.xml`` read [bytes] (real ones hold a few KiB).
MAX_PACKAGE_XML_BYTES = 256 << 10
#: Files that keep a folder and everything below it out of a search (catkin, colcon, ament).
IGNORE_MARKERS = ("CATKIN_IGNORE", "COLCON_IGNORE", "AMENT_IGNORE")
#: A package name: one path component of plain characters (ROS names are ``[a-z][a-z0-9_]*``; installed
#: folders such as ``example-robot-data`` use ``-``).
PACKAGE_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.+-]{0,127}")
#: How many found packages an unknown-package message lists.
LISTED_PACKAGES = 8
HOW_TO_ADD = ("add the folder holding it with --package-path DIR (uvms commands), package_path=[...] "
              "(uvms.load), [model] package_path (scenarios) or ROS_PACKAGE_PATH")


def package_index(package_path: Sequence[str | os.PathLike] | None = None,
                  model: str | os.PathLike | None = None) -> dict[str, Path]:
    """The ROS packages a model may use, {name: folder}, from the sources of the module docstring in order.

    Args:
        package_path: folders the user names (packages, or folders holding packages), first in precedence.
        model: the model file, whose workspace is searched last (None: a URDF string, no workspace).

    Returns:
        {package name: its folder (absolute)}, in precedence order.

    Raises:
        ModelFileNotFound: a folder of ``package_path`` does not exist or is not a folder.
    """
    index: dict[str, Path] = {}
    for folder in named_folders(package_path):
        add_new(index, find_packages(folder))
    for folder in environment_folders("ROS_PACKAGE_PATH"):
        add_new(index, find_packages(folder))
    for prefix in environment_folders("AMENT_PREFIX_PATH"):
        add_new(index, installed_packages(prefix))
    workspace = model_workspace(model) if model is not None else None
    if workspace is not None:
        add_new(index, find_packages(workspace))
    try:
        index.setdefault("example-robot-data", example_robot_data_dir().parent)
    except ModelFileNotFound:
        pass
    return index


def add_new(index: dict[str, Path], found: Mapping[str, Path]) -> None:
    """Add the packages of ``found`` whose name ``index`` does not hold yet (the first in precedence wins)."""
    for name, folder in found.items():
        index.setdefault(name, folder)


def named_folders(package_path: Sequence[str | os.PathLike] | None) -> list[Path]:
    """The folders the user named, absolute.

    Raises:
        ModelFileNotFound: one does not exist or is not a folder.
    """
    if isinstance(package_path, (str, os.PathLike)):
        raise UVMSError(f"package_path must be a list of folders, got the single {os.fspath(package_path)!r}: "
                        f"write [{os.fspath(package_path)!r}]")
    folders = []
    for given in package_path or ():
        folder = Path(given).expanduser().absolute()
        if not folder.is_dir():
            state = "is not a folder" if folder.exists() else "does not exist"
            raise ModelFileNotFound(f"package folder {str(folder)!r} {state}; package_path names folders holding ROS "
                                    "packages (package.xml), or packages themselves")
        folders.append(folder)
    return folders


def environment_folders(variable: str) -> list[Path]:
    """The existing folders of a colon-separated environment variable (absent ones are skipped, as ROS does)."""
    return [Path(p).absolute() for p in os.environ.get(variable, "").split(os.pathsep) if p and os.path.isdir(p)]


def find_packages(root: Path) -> dict[str, Path]:
    """The packages in ``root`` (a package itself, or a folder searched breadth first as the module says).

    Returns:
        {name: real path of its folder}, shallower and then alphabetically earlier folders first; a second
        package of one name is left out with a :class:`PackageSearchWarning`.
    """
    found: dict[str, Path] = {}
    top = os.path.realpath(root)
    queue = collections.deque([(root, 0)])
    seen: set[str] = set()
    while queue:
        folder, depth = queue.popleft()
        real = os.path.realpath(folder)
        if real in seen:
            continue
        seen.add(real)
        if len(seen) > MAX_PACKAGE_FOLDERS:
            warnings.warn(f"{root}: stopped searching for ROS packages after {MAX_PACKAGE_FOLDERS} folders; name "
                          "the folders that hold your packages (--package-path, package_path=)", PackageSearchWarning,
                          stacklevel=3)
            break
        if any(os.path.lexists(os.path.join(folder, marker)) for marker in IGNORE_MARKERS):
            continue
        if os.path.isfile(os.path.join(folder, "package.xml")):
            name = package_name(folder)
            if name in found:
                warnings.warn(f"{root}: two ROS packages named {name!r}: {found[name]} (used) and {real}",
                              PackageSearchWarning, stacklevel=3)
            found.setdefault(name, Path(real))  # by its real path, however the search reached it
            continue
        if depth < MAX_PACKAGE_DEPTH:
            queue.extend((child, depth + 1) for child in subfolders(folder, top))
    return found


def subfolders(folder: Path, top: str) -> list[Path]:
    """The folders below ``folder`` a search enters, by name: not hidden; a symbolic link only to inside ``top``."""
    try:
        with os.scandir(folder) as entries:
            children = sorted((entry for entry in entries if not entry.name.startswith(".")), key=lambda e: e.name)
    except OSError:  # unreadable: nothing to find there
        return []
    kept = []
    for entry in children:
        try:
            if not entry.is_dir():  # follows a link; a link loop or dangling link is not a folder
                continue
        except OSError:
            continue
        if entry.is_symlink() and os.path.commonpath([top, os.path.realpath(entry.path)]) != top:
            continue  # a link out of the searched tree
        kept.append(Path(entry.path))
    return kept


def installed_packages(prefix: Path) -> dict[str, Path]:
    """The packages of an install prefix (``<prefix>/share/<pkg>/package.xml``), named by their folder."""
    share = prefix / "share"
    try:
        with os.scandir(share) as entries:
            names = sorted(entry.name for entry in entries)
    except OSError:
        return {}
    return {name: share / name for name in names if PACKAGE_NAME.fullmatch(name)
            and os.path.isfile(share / name / "package.xml")}


def package_name(folder: Path) -> str:
    """The ``<name>`` of a folder's ``package.xml``, else (no name, an unreadable file: with a warning) the folder's.

    The file is read within :data:`MAX_PACKAGE_XML_BYTES`, and one that declares an entity is not parsed (an
    entity can expand to gigabytes).
    """
    path = folder / "package.xml"
    try:
        data = read_file(path, "package.xml", MAX_PACKAGE_XML_BYTES)
        if b"<!ENTITY" in data:
            raise UVMSError(f"{path}: declares an XML entity, which a package.xml has no use for")
        name = (ET.fromstring(data).findtext("name") or "").strip()
    except (UVMSError, ET.ParseError) as exc:
        warnings.warn(f"{path}: cannot read the package name ({' '.join(str(exc).split())}); named {folder.name!r} "
                      "after its folder", PackageSearchWarning, stacklevel=4)
        return folder.name
    return name if PACKAGE_NAME.fullmatch(name) else folder.name


def model_workspace(model: str | os.PathLike) -> Path | None:
    """The folder searched for the packages of a model's own workspace, or None when the model is in no package.

    Walking up at most :data:`MAX_WORKSPACE_LEVELS` folders from the model file: when one of them holds
    ``package.xml`` (the model lies in a ROS package), the nearest folder named ``src`` above that package (a
    colcon/catkin workspace's sources) within those levels, else that package's own folder: without a workspace
    the folders beside the package (a downloads folder) are not searched, so ``$(find other_pkg)`` of a stranger's
    model cannot reach them unless the user names them (``--package-path``, ``ROS_PACKAGE_PATH``).
    """
    ancestors = list(Path(os.path.abspath(model)).parents)[:MAX_WORKSPACE_LEVELS]
    package = next((folder for folder in ancestors if (folder / "package.xml").is_file()), None)
    if package is None:
        return None
    above = ancestors[ancestors.index(package) + 1:]  # a package's own src/ is not a workspace
    return next((folder for folder in above if folder.name == "src"), package)


def unknown_package(name: str, packages: Mapping[str, Path], model: str | os.PathLike) -> str:
    """The one-line error of ``$(find name)`` in a xacro ``model`` when the index lacks the package: where uvms
    looked, what it found, how to add a folder.

    Returns:
        "<model>: $(find x): no ROS package 'x' (looked in: ...; found 3: a, b, c); add the folder holding it ...".
    """
    return f"{model}: $(find {name}): {package_search(name, packages, model)}"


def package_search(name: str, packages: Mapping[str, Path], model: str | os.PathLike) -> str:
    """Where the index of ``model`` looked for the package ``name`` it lacks, what it found, how to add a folder:
    "no ROS package 'x' (looked in: ...; found 3: a, b, c); add the folder holding it ..." (a ``$(find)``, a
    ``package://`` mesh)."""
    places = ["the folders named by package_path (if any)"]
    for variable in ("ROS_PACKAGE_PATH", "AMENT_PREFIX_PATH"):
        places.append(f"{variable}={os.environ[variable]}" if os.environ.get(variable) else f"no {variable}")
    workspace = model_workspace(model) if model else None
    if workspace is None:
        places.append("no workspace (the model is in no package)")
    elif (workspace / "package.xml").is_file():
        places.append(f"the model's own package {workspace} (no workspace: no src folder above it)")
    else:
        places.append(f"the model's workspace {workspace}")
    listed = ", ".join(list(packages)[:LISTED_PACKAGES]) + (", ..." if len(packages) > LISTED_PACKAGES else "")
    return (f"no ROS package {name!r} (looked in: {'; '.join(places)}; found {len(packages)}: {listed or 'none'}); "
            f"{HOW_TO_ADD}")
