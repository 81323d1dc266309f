"""Where model files and their meshes live: shipped models, example-robot-data, package:// URIs."""

from __future__ import annotations

import functools
import os
from collections.abc import Iterable, Sequence
from importlib import metadata
from pathlib import Path

from ..errors import ModelFileNotFound, ModelParseError

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


@functools.lru_cache(maxsize=1)
def example_robot_data_dir() -> Path:
    """The ``robots/`` folder installed by the ``example-robot-data`` wheel (data only).

    Raises:
        ModelFileNotFound: the package is not installed.
    """
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


def package_search_roots(package_dirs: Sequence[str | os.PathLike] | None = None) -> list[Path]:
    """Folders in which ``package://<pkg>/...`` is looked up, in order.

    ``package_dirs`` first, then ``ROS_PACKAGE_PATH``, then ``<prefix>/share`` of
    ``AMENT_PREFIX_PATH``, then the ``share`` folder of example-robot-data
    (its URDFs say ``package://example-robot-data/robots/...``).
    """
    roots = [Path(p) for p in package_dirs or ()]
    roots += [Path(p) for p in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if p]
    roots += [Path(p) / "share" for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    try:
        roots.append(example_robot_data_dir().parent.parent)
    except ModelFileNotFound:
        pass
    return roots


def resolve_uri(uri: str, base_dir: Path | None, roots: Iterable[Path]) -> Path | None:
    """Resolve a mesh URI (``package://``, ``file://`` or a relative path) to an existing file.

    Args:
        uri: the ``filename`` of a URDF ``<mesh>``.
        base_dir: folder of the model file, for relative paths (None for XML strings).
        roots: package search roots (see :func:`package_search_roots`).

    Returns:
        The file, or None when it cannot be found.
    """
    if uri.startswith("package://"):
        package, _, relative = uri[len("package://") :].partition("/")
        for root in roots:
            # a root is either the package folder itself or a folder holding packages
            candidate = root / relative if root.name == package else root / package / relative
            if candidate.is_file():
                return candidate
        return None
    path = Path(uri[len("file://") :] if uri.startswith("file://") else uri)
    if not path.is_absolute() and base_dir is not None:
        path = base_dir / path
    return path if path.is_file() else None


def read_yaml(path: str | os.PathLike, what: str) -> object:
    """The document of a YAML data file beside a model (hydrodynamics, thrusters), read safely (data only).

    Args:
        path: the file; what: what it holds, for the messages ("hydrodynamics", "thrusters").

    Raises:
        ModelFileNotFound: the file cannot be read.
        ModelParseError: not YAML.
    """
    import yaml

    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ModelFileNotFound(f"{path}: cannot read the {what} file ({exc})") from None
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ModelParseError(f"{path}: malformed YAML ({' '.join(str(exc).split())})") from None
