"""Where scenario files live (a path, or the name of a scenario shipped in the repository's ``scenarios/``), and
the folders a scenario names.

``uvms run hoang2011_w1`` runs ``scenarios/hoang2011_w1.toml`` of the installed repository, as
``uvms info hoang2011`` loads ``models/hoang2011/`` (:mod:`uvms.model.resources`). A file that exists
wins over a shipped name, so a scenario of one's own is never shadowed.
"""

from __future__ import annotations

import difflib
import os
from pathlib import Path

from ..errors import ScenarioError

#: The repository's `scenarios/` folder (present in a source checkout or an editable install).
SCENARIOS_DIR = Path(__file__).resolve().parents[2] / "scenarios"


def shipped_scenarios() -> dict[str, Path]:
    """The scenarios shipped in `scenarios/`, by name (the file stem).

    Returns:
        {name: path of ``scenarios/<name>.toml``}, sorted by name; empty when the package was installed
        without the repository's `scenarios/` folder.
    """
    if not SCENARIOS_DIR.is_dir():
        return {}
    return {path.stem: path for path in sorted(SCENARIOS_DIR.glob("*.toml")) if path.is_file()}


def resolve_scenario_path(name_or_path: str | os.PathLike) -> Path:
    """Turn a scenario file path or the name of a shipped scenario (``"hoang2011_w1"``) into a path.

    Args:
        name_or_path: a ``.toml`` path, or the stem of a file in `scenarios/`.

    Returns:
        The path as given when it is a file, else the shipped scenario's file (absolute).

    Raises:
        ScenarioError: neither an existing file nor a shipped scenario name; the message lists the close
            shipped names, else all of them.
    """
    path = Path(name_or_path).expanduser()
    if path.is_file():
        return path
    shipped = shipped_scenarios()
    name = str(name_or_path)
    if name in shipped:
        return shipped[name]
    if path.exists():
        raise ScenarioError(f"scenario path {name!r} is not a file")
    close = difflib.get_close_matches(path.stem if path.suffix == ".toml" else name, list(shipped), n=5, cutoff=0.5)
    if close:
        hint = f"close shipped scenarios: {', '.join(close)}"
    else:
        hint = f"shipped scenarios: {', '.join(shipped) or 'none found'}"
    raise ScenarioError(f"scenario file {name!r} does not exist and is not a shipped scenario name; give a .toml "
                        f"path or a shipped name ({hint})")


def scenario_folders(names: list, scenario_file: str | os.PathLike, key: str) -> list[str]:
    """The folders a scenario names (``model.package_path``), absolute: a relative name is relative to the scenario
    file's folder. They are only read from (a name from a scenario never becomes a place to write).

    Raises:
        ScenarioError: an entry that is not a folder name (a non-empty string).
    """
    if not all(isinstance(name, str) and name for name in names):
        raise ScenarioError(f"{scenario_file}: {key} must be a list of folders (strings, relative to the scenario "
                            f"file's folder or absolute), got {names!r}")
    return [str((Path(scenario_file).parent / name).resolve()) for name in names]


def scenario_file(name: object, scenario_file: str | os.PathLike, key: str) -> str:
    """A file a scenario names (an obstacle's mesh, an SRDF), absolute: a relative path inside the scenario file's
    folder. Confined to that folder (``..`` or a symbolic link leading out of it finds nothing), as a ``package://``
    URI stays inside its package (:func:`uvms.model.resources.resolve_uri`): a scenario from someone else reads only
    the files that came with it.

    Raises:
        ScenarioError: not a plain relative path, a path leading out of the folder, or no such file.
    """
    folder = Path(scenario_file).resolve().parent
    if not isinstance(name, str) or not name or Path(name).is_absolute():
        raise ScenarioError(f"{scenario_file}: {key} must be a file path relative to the scenario's folder "
                            f"({folder}), got {name!r}")
    path = (folder / name).resolve()
    if not path.is_relative_to(folder):
        raise ScenarioError(f"{scenario_file}: {key} = {name!r} leads out of the scenario's folder ({folder}); "
                            f"put the file beside the scenario or below it")
    if not path.is_file():
        raise ScenarioError(f"{scenario_file}: {key} = {name!r} is not a file in the scenario's folder ({folder})")
    return str(path)
