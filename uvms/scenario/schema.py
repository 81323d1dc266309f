"""Reading a scenario file: the bounded TOML read, ``--set KEY=VALUE`` overrides, and the check into the typed spec.

The sections and their keys are the frozen dataclasses of :mod:`uvms.scenario.spec` (one source of the checks, the
defaults and the docs' scenario reference); unknown keys are rejected with the list of valid ones, and ``--set``
overrides any key of the raw file before the check (dotted path, e.g. ``solver.gain=2`` or ``model.args.l1=0.6``).
"""

from __future__ import annotations

import copy
import dataclasses
import os
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

from ..errors import ScenarioError
from ..io.names import plain_file_name
from ..model.resources import MAX_TOML_BYTES, read_text
from ..tasks.objectives import file_keys
from .controllers import CONTROLLERS
from .resources import resolve_scenario_path, scenario_file, scenario_folders
from .spec import MAX_MAGNITUDE, ScenarioSpec, check_scenario


# ------------------------------------------------------------------ parsing
def read_scenario(path: str | os.PathLike, overrides: Sequence[str] = ()) -> ScenarioSpec:
    """Read, override and check a scenario file into its spec; relative model paths and package folders become
    absolute.

    Args:
        path: a ``.toml`` file or the name of a shipped scenario (``"hoang2011_w1"``,
            :func:`~uvms.scenario.resources.resolve_scenario_path`).
        overrides: ``SECTION.KEY=VALUE`` strings.

    Raises:
        ScenarioError: unknown file or name, unreadable file, bad TOML, unknown key, wrong type, impossible value.
    """
    path = resolve_scenario_path(path)
    return scenario_from_raw(read_toml(path), path, overrides)


def read_toml(path: str | os.PathLike) -> dict:
    """The raw table of a scenario file or shipped scenario name (not validated).

    The file is read by :func:`uvms.model.resources.read_text` (a regular file of at most
    :data:`~uvms.model.resources.MAX_TOML_BYTES`, its size checked first).

    Raises:
        ScenarioError: unknown file or name, unreadable or too large, not TOML (nested too deeply, a number of
            more digits than Python converts).
    """
    path = resolve_scenario_path(path)
    text = read_text(path, "scenario", MAX_TOML_BYTES, ScenarioError)
    try:
        return tomllib.loads(text)
    except (RecursionError, ValueError) as exc:  # TOMLDecodeError is a ValueError
        raise toml_error(exc, str(path)) from None


def toml_error(exc: Exception, origin: str) -> ScenarioError:
    """The ScenarioError of a failure of tomllib: bad syntax, nesting beyond the stack, a number of too many digits
    (Python converts at most ``sys.get_int_max_str_digits()``)."""
    if isinstance(exc, RecursionError):
        return ScenarioError(f"{origin}: invalid TOML: arrays or tables nested too deeply (a scenario nests "
                             "a few levels)")
    if isinstance(exc, tomllib.TOMLDecodeError) or "integer string conversion" not in str(exc):
        return ScenarioError(f"{origin}: invalid TOML ({exc})")
    return ScenarioError(f"{origin}: invalid TOML: a number has too many digits ({str(exc).split(':')[0]}); "
                         f"scenario numbers are SI values with |x| <= {MAX_MAGNITUDE:.0e}")


def scenario_from_raw(raw: Mapping, path: str | os.PathLike, overrides: Sequence[str] = ()) -> ScenarioSpec:
    """Override and check the raw table of the scenario file ``path`` (left unchanged: it is copied); the paths it
    names made absolute (files inside the scenario's folder), ``scenario.name`` the file's stem when not given."""
    path = Path(path)
    raw = copy.deepcopy(dict(raw))
    for override in overrides:
        apply_override(raw, override)
    spec = check_scenario(raw, path, CONTROLLERS)
    model_path = spec.model.path
    if not Path(model_path).is_absolute() and (path.parent / model_path).exists():
        model_path = str((path.parent / model_path).resolve())
    folders = tuple(scenario_folders(list(spec.model.package_path), path, "model.package_path"))
    model = dataclasses.replace(spec.model, path=model_path, package_path=folders)
    plant = spec.plant
    if plant.hydrodynamics:
        plant = dataclasses.replace(plant, hydrodynamics=scenario_file(plant.hydrodynamics, path,
                                                                       "plant.hydrodynamics"))
    inequalities = []
    for index, table in enumerate(spec.inequalities):
        files = {key: scenario_file(table.keys[key], path, f"inequalities[{index}].{key}")
                 for key in file_keys(table.type) if key in table.keys}
        inequalities.append(dataclasses.replace(table, keys={**table.keys, **files}))
    label = dataclasses.replace(spec.scenario, name=spec.scenario.name or plain_file_name(path.stem, "scenario"))
    return dataclasses.replace(spec, model=model, plant=plant, inequalities=tuple(inequalities),
                               scenario=label)


def parse_value(text: str) -> Any:
    """A --set value as TOML (number, bool, list, quoted string); bare words stay strings.

    Raises:
        ScenarioError: TOML nested too deeply, or a number of too many digits.
    """
    try:
        return tomllib.loads(f"value = {text}")["value"]
    except tomllib.TOMLDecodeError:
        return text
    except (RecursionError, ValueError) as exc:
        raise toml_error(exc, f"--set value {text[:40]!r}{'...' if len(text) > 40 else ''}") from None


def apply_override(raw: dict, assignment: str) -> None:
    """Apply ``section.key[.sub]=VALUE`` to the raw scenario."""
    key, sep, text = assignment.partition("=")
    parts = key.strip().split(".")
    if not sep or len(parts) < 2 or not all(parts):
        raise ScenarioError("--set expects SECTION.KEY=VALUE (e.g. solver.gain=2, "
                            f"model.args.l1=0.6), got {assignment!r}")
    node = raw
    for part in parts[:-1]:
        node = node.setdefault(part, {})
        if not isinstance(node, dict):
            raise ScenarioError(f"--set {key}: {part!r} is not a table")
    node[parts[-1]] = parse_value(text.strip())
