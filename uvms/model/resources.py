"""Where model files and their meshes live (shipped models, example-robot-data, ``package://`` URIs through the
package index of :mod:`uvms.model.packages`), and reading them.

A file from a stranger is read by :func:`read_file` only: a regular file (never a FIFO or a device), its size
checked before a byte is read. YAML goes through :func:`read_yaml` (aliases counted), the includes of a xacro
through :func:`uvms.model.includes.walk_xacro` (each file once, within caps on files, inclusions, bytes and time).
"""

from __future__ import annotations

import functools
import json
import os
import stat
from collections.abc import Mapping
from pathlib import Path

from ..errors import ModelFileNotFound, ModelParseError, UVMSError

#: Caps of the files read, checked on a file's size before it is read. A URDF or xacro file: the cap of URDF
#: text (``checks.MAX_URDF_BYTES``, 32 MiB; the shipped models are under 40 KiB). A TOML scenario: 4 MiB (the
#: shipped ones are under 4 KiB). A YAML data file: 1 MiB (the shipped ones are 3 KiB; PyYAML's safe loader,
#: pure Python so that deep nesting is a RecursionError rather than a crash of libyaml, reads about 0.2 MiB/s).
MAX_TOML_BYTES = 4 << 20
MAX_YAML_BYTES = 1 << 20
#: A JSON record of a run (``metrics.json``) read back: 4 MiB (a run writes a few KiB).
MAX_JSON_BYTES = 4 << 20
#: The most values (scalars, lists, mappings) a YAML file may hold, its aliases (``*name``) counted at each use:
#: nine nested anchors of nine items each are 9**9 values in 300 bytes.
MAX_YAML_VALUES = 100_000

#: The repository's `models/` folder (present in a source checkout or an editable install).
MODELS_DIR = Path(__file__).resolve().parents[2] / "models"


def shipped_models() -> dict[str, Path]:
    """The models shipped in `models/`, by system name.

    Returns:
        {system name: path of its main ``*.urdf.xacro``}, empty when the
        package was installed without the repository's `models/` folder.
    """
    found: dict[str, Path] = {}
    if MODELS_DIR.is_dir():
        for folder in sorted(p for p in MODELS_DIR.iterdir() if p.is_dir()):
            files = sorted(folder.glob("*.urdf.xacro")) + sorted(folder.glob("*.urdf"))
            if files:
                found[folder.name] = files[0]
    return found


def resolve_model_path(name_or_path: str | os.PathLike) -> Path:
    """Turn a file path or the name of a shipped model (``"hoang2011"``) into a path.

    Raises:
        ModelFileNotFound: neither an existing file nor a shipped model name.
    """
    path = Path(name_or_path).expanduser()
    if path.is_file():
        return path
    shipped = shipped_models()
    if str(name_or_path) in shipped:
        return shipped[str(name_or_path)]
    if path.exists():
        raise ModelFileNotFound(f"model path {str(path)!r} is not a file")
    if path.is_symlink():
        try:
            path.resolve(strict=True)
        except (RuntimeError, OSError) as exc:  # a loop raises RuntimeError (3.11-3.12) or OSError (ELOOP)
            raise ModelFileNotFound(f"model path {str(path)!r} is a symbolic link that leads nowhere "
                                    f"({getattr(exc, 'strerror', None) or exc}); give a real file") from None
    names = ", ".join(shipped) or "none found"
    raise ModelFileNotFound(
        f"model file {str(path)!r} does not exist; give a .urdf/.xacro path or a shipped model ({names})"
    )


def model_file(source: str | os.PathLike) -> Path | None:
    """The file of a model source (a path or a shipped model name; else ModelFileNotFound), None for URDF text."""
    if isinstance(source, str) and source.lstrip().startswith("<"):
        return None
    return resolve_model_path(source)


@functools.lru_cache(maxsize=1)
def example_robot_data_dir() -> Path:
    """The ``robots/`` folder installed by the ``example-robot-data`` wheel (data only).

    Raises:
        ModelFileNotFound: the package is not installed.
    """
    from importlib import metadata  # here, not at import: ~15 ms (email, zipfile) that models of files never need

    try:
        dist = metadata.distribution("example-robot-data")
    except metadata.PackageNotFoundError as exc:
        raise ModelFileNotFound("example-robot-data is not installed: pip install example-robot-data") from exc
    for file in dist.files or ():
        parts = Path(file).parts
        if "robots" in parts and parts[-1].endswith(".urdf"):
            index = parts.index("robots")
            return Path(dist.locate_file(Path(*parts[: index + 1]))).resolve()
    raise ModelFileNotFound("example-robot-data is installed but holds no robots/ folder")


def example_robot_urdf(name: str) -> Path:
    """The URDF of an example-robot-data robot, e.g. ``"panda"``, ``"ur5"``, ``"z1"``.

    A name matches ``robots/*/urdf/<name>.urdf`` first, then
    ``<name>_robot.urdf``, then the only URDF of ``robots/<name>_description``.

    Raises:
        ModelFileNotFound: no such robot; the message lists the available names.
    """
    robots = example_robot_data_dir()
    urdfs = sorted(robots.glob("*/urdf/*.urdf"))
    for candidate in (f"{name}.urdf", f"{name}_robot.urdf"):
        for path in urdfs:
            if path.name == candidate:
                return path
    folder = robots / f"{name}_description" / "urdf"
    own = sorted(folder.glob("*.urdf"))
    if len(own) >= 1:
        return own[0]
    names = sorted({p.stem for p in urdfs})
    raise ModelFileNotFound(f"example-robot-data has no robot {name!r}; available: {', '.join(names)}")


def resolve_uri(uri: str, base_dir: Path | None, packages: Mapping[str, Path]) -> Path | None:
    """Resolve a mesh URI (``package://``, ``file://`` or a relative path) to an existing file.

    A ``package://<pkg>/<path>`` is looked up in ``packages`` and stays inside that folder: ``..`` that climbs out
    of it (``package://example-robot-data/../../etc/hostname``) finds nothing. The check is on the path as
    written (``..`` resolved, symbolic links not followed), so a package installed as links to its sources
    (``colcon build --symlink-install``) keeps its meshes.

    Args:
        uri: the ``filename`` of a URDF ``<mesh>``.
        base_dir: folder of the model file, for relative paths (None for XML strings).
        packages: the package index, {name: folder} (:func:`uvms.model.packages.package_index`).

    Returns:
        The file, or None when it cannot be found.
    """
    if uri.startswith("package://"):
        package, _, relative = uri[len("package://") :].partition("/")
        if package not in packages or os.path.isabs(relative):
            return None
        folder = Path(os.path.normpath(packages[package]))
        candidate = Path(os.path.normpath(folder / relative))
        return candidate if candidate.is_relative_to(folder) and candidate.is_file() else None
    path = Path(uri[len("file://") :] if uri.startswith("file://") else uri)
    if not path.is_absolute() and base_dir is not None:
        path = base_dir / path
    return path if path.is_file() else None


# ------------------------------------------------------------------ reading files from strangers
def read_file(path: str | os.PathLike, what: str, limit: int, error: type[UVMSError] = ModelFileNotFound) -> bytes:
    """The bytes of a regular file of at most ``limit`` bytes: the one way uvms reads a model, scenario or data file.

    The file is checked before it is opened (a FIFO or a device such as ``/dev/stdin`` would block a read, and
    a sparse file of 30 GB would fill the memory) and again once open (it may have been replaced in between).

    Args:
        path: the file.
        what: what it holds, for the messages ("model", "scenario", "hydrodynamics YAML").
        limit: the most bytes accepted (``MAX_URDF_BYTES``, ``MAX_TOML_BYTES``, ``MAX_YAML_BYTES``).
        error: the UVMSError subclass raised.

    Raises:
        error: the file does not exist, is not a regular file, is larger than ``limit`` or cannot be read.
    """

    def refuse(info: os.stat_result) -> None:
        if not stat.S_ISREG(info.st_mode):
            raise error(f"{path}: the {what} file is {file_kind(info)}, not a regular file; give a file")
        if info.st_size > limit:
            raise error(f"{path}: the {what} file holds {info.st_size / 2**20:,.1f} MiB; at most {limit / 2**20:g} "
                        f"MiB are accepted (no real one is that large)")

    try:
        refuse(os.stat(path))
        descriptor = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
        with os.fdopen(descriptor, "rb") as handle:
            refuse(os.fstat(handle.fileno()))
            data = handle.read(limit + 1)
    except FileNotFoundError:
        raise error(f"{path}: the {what} file does not exist") from None
    except OSError as exc:
        raise error(f"{path}: cannot read the {what} file ({exc.strerror or exc}); give a readable file") from None
    if len(data) > limit:  # it grew since it was checked
        raise error(f"{path}: the {what} file holds more than {limit / 2**20:g} MiB; at most that is accepted")
    return data


def file_kind(info: os.stat_result) -> str:
    """What a file is, for messages: "a regular file", "a folder", "a FIFO" or "a device or socket"."""
    if stat.S_ISREG(info.st_mode):
        return "a regular file"
    return "a folder" if stat.S_ISDIR(info.st_mode) else "a FIFO" if stat.S_ISFIFO(info.st_mode) else (
        "a device or socket")


def read_text(path: str | os.PathLike, what: str, limit: int, error: type[UVMSError] = ModelFileNotFound) -> str:
    """The UTF-8 text of a file read by :func:`read_file` (same arguments).

    Raises:
        error: as :func:`read_file`, or the file is not UTF-8 text.
    """
    data = read_file(path, what, limit, error)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise error(f"{path}: the {what} file is not UTF-8 text ({exc.reason} at byte {exc.start})") from None


def read_json(path: str | os.PathLike, what: str, error: type[UVMSError]) -> object:
    """The document of a JSON file that may come from someone else (a run folder's ``metrics.json``).

    At most ``MAX_JSON_BYTES``, read by :func:`read_file`; nesting deep enough to exhaust Python's recursion is
    refused like malformed JSON.

    Raises:
        error: the file cannot be read, is too large, or is not JSON.
    """
    text = read_text(path, what, MAX_JSON_BYTES, error)
    try:
        return json.loads(text)
    except (ValueError, RecursionError) as exc:
        reason = "nested too deeply" if isinstance(exc, RecursionError) else str(exc)
        raise error(f"{path}: the {what} file is not valid JSON ({reason})") from None


def read_yaml(path: str | os.PathLike, what: str) -> object:
    """The document of a YAML data file beside a model (hydrodynamics, thrusters), read safely (data only).

    At most ``MAX_YAML_BYTES`` and ``MAX_YAML_VALUES`` values, aliases counted at each use (an alias bomb is
    refused at once); an alias inside its own anchor (a recursive document) is refused.

    Args:
        path: the file; what: what it holds, for the messages ("hydrodynamics", "thrusters").

    Raises:
        ModelFileNotFound: the file cannot be read, or is too large.
        ModelParseError: not YAML, nested too deeply, too many values or a recursive alias.
    """
    import yaml

    path = Path(path)
    loader = yaml.SafeLoader(read_text(path, f"{what} YAML", MAX_YAML_BYTES))
    try:
        node = loader.get_single_node()
        if node is not None:
            count_yaml_values(node, path)
        return None if node is None else loader.construct_document(node)
    except yaml.YAMLError as exc:
        raise ModelParseError(f"{path}: malformed YAML ({' '.join(str(exc).split())})") from None
    except RecursionError:
        raise ModelParseError(f"{path}: the YAML is nested too deeply; a data file nests a few levels") from None
    finally:
        loader.dispose()


def count_yaml_values(root: object, path: Path) -> int:
    """The values of a composed YAML document with its aliases expanded, counted without expanding them.

    Raises:
        ModelParseError: more than ``MAX_YAML_VALUES``, or an alias inside its own anchor.
    """
    import yaml

    def children(node: yaml.Node) -> list:
        if isinstance(node, yaml.MappingNode):
            return [item for pair in node.value for item in pair]
        return node.value if isinstance(node, yaml.SequenceNode) else []

    sizes: dict[int, int] = {}  # id(node) -> its values, aliases expanded
    open_nodes: set[int] = set()  # the nodes being counted: the ancestors of the current one
    stack = [(root, False)]
    while stack:
        node, finished = stack.pop()
        if finished:
            open_nodes.discard(id(node))
            sizes[id(node)] = 1 + sum(sizes[id(child)] for child in children(node))
            if sizes[id(node)] > MAX_YAML_VALUES:
                raise ModelParseError(f"{path}: the YAML holds more than {MAX_YAML_VALUES} values with its aliases "
                                      f"(*name) expanded; a data file holds a few hundred: write the values out")
        elif id(node) in open_nodes:
            raise ModelParseError(f"{path}: a YAML alias is used inside its own anchor (a recursive document); "
                                  "a data file is a tree of values")
        elif id(node) not in sizes:
            open_nodes.add(id(node))
            stack.append((node, True))
            stack.extend((child, False) for child in children(node))
    return sizes[id(root)]
