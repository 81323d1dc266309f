"""The scenario file: its schema (sections, keys, types, defaults, bounds), reading, overrides and checks.

The schema is :data:`SCHEMA`; unknown keys are rejected with the list of valid ones, and ``--set KEY=VALUE``
overrides any key (dotted path, e.g. ``solver.gain=2`` or ``model.args.l1=0.6``).
"""

from __future__ import annotations

import copy
import math
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
from ..io.names import NAME_RULE, is_plain_name, plain_file_name
from ..model.resources import MAX_TOML_BYTES, read_text
from ..solvers import SOLVERS
from ..tasks.objectives import file_keys
from .inequalities import check_tables
from .resources import resolve_scenario_path, scenario_file, scenario_folders
from .schema_dynamics import EXCITATION, NUMBER, NUMBERS, PLANT, VEHICLE_CONTROL

#: Defaults of [outputs] position_tolerance [m] and orientation_tolerance [rad]: a run whose task error exceeds
#: them is reported as not meeting its task (a terminal warning, metrics.json "verdict"). 1 cm and 1 degree: far
#: above what closed-loop kinematic control reaches (1e-10 m), and an error a user sees in a figure.
DEFAULT_POSITION_TOLERANCE = 0.01
DEFAULT_ORIENTATION_TOLERANCE = 0.0175
#: solver.method values: the solvers registered in uvms.solvers.SOLVERS (CLIK, classic/robust task priority,
#: santos2006's kinematic constraint, and the two that enforce [[inequalities]]: set-based (iCAT) and the QP hierarchy).
SOLVER_METHODS = SOLVERS.keys()  # a live view: a method registered later is valid
REQUIRED = object()
ANIMATION_SUFFIXES = (".gif", ".mp4")
#: The largest magnitude of a number in a scenario (SI units; model.args excepted, the model checks them). No gain
#: [1/s], damping, weight, length [m], speed [m/s], time [s] or angle [rad] of a vehicle-manipulator run comes near it,
#: and beyond it products such as damping**2, gain * dt or weight ratios overflow or swamp the solvers' doubles.
MAX_MAGNITUDE = 1e6
#: Keys that also have a sign: key -> (lowest value, whether the lowest value itself is excluded, meaning).
LOWER_BOUNDS: dict[str, tuple[float, bool, str]] = {
    "simulation.dt": (0.0, True, "the integration step [s]"),
    "simulation.duration": (0.0, False, "the run length [s]; 0: the trajectory's"),
    "trajectory.duration": (0.0, True, "the trajectory's length [s]"),
    "trajectory.accel_time": (0.0, False, "the acceleration time [s]"),
    "trajectory.laps": (0.0, False, "laps of the circle; 0: one pass"),
    "solver.damping": (0.0, False, "the DLS damping"),
    "solver.damping_epsilon": (0.0, False, "the singular-value threshold of the variable damping"),
    "solver.damping_max": (0.0, False, "the largest variable damping"),
    "solver.eta": (0.0, False, "the weight of the iCAT regularization"),
    "solver.regularization": (0.0, False, "the weight of |x|^2 in the QPs"),
    "outputs.position_tolerance": (0.0, True, "the largest position error [m] of a run said to meet its task"),
    "outputs.orientation_tolerance": (0.0, True, "the largest orientation error [rad] of a run said to meet its task"),
}

#: section -> key -> (accepted types, default, allowed values or None). "args"/"velocities" hold free tables.
SCHEMA: dict[str, dict[str, tuple]] = {
    "scenario": {
        "name": (str, "", None),
        "description": (str, "", None),
    },
    "model": {
        "path": (str, REQUIRED, None),
        "base": (str, "", ("", "floating", "planar", "fixed")),
        "ee": (str, "", None),
        "args": (dict, {}, None),
        "package_path": (list, [], None),  # folders of ROS packages ($(find), package://), from the scenario's folder
        "arm_joints": (list, None, None),  # names of the joints that move, others frozen; absent: uvms.load's rule
    },
    "task": {
        "frame": (str, "", None),
        "frames": (list, [], None),
        "axes": (list, [], None),
        "orientation_error": (str, "log", ("log", "euler")),
    },
    "trajectory": {
        "type": (str, "circle", ("circle", "line", "pose", "ramps", "hold")),
        "start": (NUMBERS, [], None),
        "center": (NUMBERS, [], None),
        "center_offset": (NUMBERS, [], None),
        "normal": (NUMBERS, [0.0, 0.0, 1.0], None),
        "end": (NUMBERS, [], None),
        "end_offset": (NUMBERS, [], None),
        "orientation": (NUMBERS, [], None),
        "end_orientation": (NUMBERS, [], None),
        "law": (str, "trapezoid", ("trapezoid", "cubic", "quintic")),
        "speed": (NUMBER, 0.0, None),
        "laps": (NUMBER, 0.0, None),
        "duration": (NUMBER, REQUIRED, None),
        "accel_time": (NUMBER, 0.0, None),
        "velocity": (NUMBERS, [], None),
    },
    "solver": {
        "method": (str, "clik", SOLVER_METHODS),
        "gain": ((int, float, list), 1.0, None),
        "weights": (NUMBERS, [], None),
        "damping": (NUMBER, 0.0, None),
        "damping_epsilon": (NUMBER, 0.0, None),
        "damping_max": (NUMBER, 0.0, None),
        "alpha": (NUMBER, 0.0, None),
        "joint_limit_weights": ((int, float, list), 1.0, None),
        "free_floating": (bool, False, None),
        "enforce_limits": (bool, False, None),
        "priority": (str, "robust", ("robust", "classic")),
        "eta": (NUMBER, 1.0, None),  # set_based: weight of the iCAT (I - Q) regularization
        "regularization": (NUMBER, 1e-9, None),  # hqp: weight of |x|^2_W in every level's QP
    },
    "vehicle": {
        "velocities": (dict, {}, None),
        "heading": (NUMBER, None, None),
        "depth": (NUMBER, None, None),
        "gain": (NUMBER, 1.0, None),
        "hold": (bool, True, None),
    },
    "initial": {
        "method": (str, "given", ("given", "optimize")),
        "base": (NUMBERS, [], None),
        "arm": ((list, dict), [], None),  # [rad or m] n_arm numbers, or {joint = value} (others at 0, neutral)
        "fixed_base": (list, [], None),
    },
    "simulation": {
        "dt": (NUMBER, REQUIRED, None),
        "duration": (NUMBER, 0.0, None),
        "integrator": (str, "rk4", ("euler", "rk4")),
    },
    "plant": PLANT,
    "vehicle_control": VEHICLE_CONTROL,
    "excitation": EXCITATION,
    "outputs": {
        "figures": (bool, True, None),
        "animation": (str, "", None),
        "position_tolerance": (NUMBER, DEFAULT_POSITION_TOLERANCE, None),
        "orientation_tolerance": (NUMBER, DEFAULT_ORIENTATION_TOLERANCE, None),
        "bag": (bool, False, None),  # also write the run as a ROS 2 bag (bag/, MCAP) through uvms.scenario.bags.writer
    },
    "study": {"samples": (list, [], None), "n": (int, 0, None), "seed": (int, 0, None), "set": (list, [], None),
              "method": (str, "random", ("random", "lhs", "sobol"))},  # uvms study: Monte Carlo trials (scenario.study)
}
#: keys of one [[phases]] table (a sequence scenario: several frames, no [trajectory]); see uvms.control.sequence.
PHASE_SCHEMA: dict[str, tuple] = {
    "name": (str, "", None),
    "duration": (NUMBER, REQUIRED, None),
    "offsets": (dict, {}, None),
    "joints": (dict, {}, None),
    "distance": (NUMBER, None, None),
}
REQUIRED_SECTIONS = ("model", "trajectory", "simulation")
SEQUENCE_REQUIRED_SECTIONS = ("model", "phases", "simulation")


# ------------------------------------------------------------------ parsing
def read_scenario(path: str | os.PathLike, overrides: Sequence[str] = ()) -> dict:
    """Read, override and validate a scenario file; relative model paths and package folders become absolute.

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


def scenario_from_raw(raw: Mapping, path: str | os.PathLike, overrides: Sequence[str] = ()) -> dict:
    """Override and validate the raw table of the scenario file ``path`` (left unchanged: it is copied)."""
    path = Path(path)
    raw = copy.deepcopy(dict(raw))
    for override in overrides:
        apply_override(raw, override)
    scenario = validate(raw, str(path))
    model_path = Path(scenario["model"]["path"])
    if not model_path.is_absolute() and (path.parent / model_path).exists():
        scenario["model"]["path"] = str((path.parent / model_path).resolve())
    scenario["model"]["package_path"] = scenario_folders(scenario["model"]["package_path"], path, "model.package_path")
    if scenario["plant"]["hydrodynamics"]:
        scenario["plant"]["hydrodynamics"] = scenario_file(scenario["plant"]["hydrodynamics"], path,
                                                           "plant.hydrodynamics")
    for index, table in enumerate(scenario["inequalities"]):
        for key in set(file_keys(table["type"])) & set(table):
            table[key] = scenario_file(table[key], path, f"inequalities[{index}].{key}")
    scenario["scenario"]["name"] = scenario["scenario"]["name"] or plain_file_name(path.stem, "scenario")
    return scenario


def named_files(scenario: dict) -> list[str]:
    """The files a checked scenario names besides its model, absolute (:func:`scenario_from_raw`): the plant's
    hydrodynamics YAML and the inequalities' files (meshes). What a run reads, which ``--watch`` watches and an
    output folder must not hold."""
    files = [scenario["plant"]["hydrodynamics"]] if scenario["plant"]["hydrodynamics"] else []
    for table in scenario["inequalities"]:
        files += [table[key] for key in file_keys(table["type"]) if key in table]
    return files


def check_name(name: str, value: str, origin: str, role: str, suffixes: Sequence[str] = (), example: str = "") -> str:
    """A scenario string that becomes a file or folder name (``scenario.name`` -> ``out/<name>``,
    ``outputs.animation``): a plain name (:func:`uvms.io.names.is_plain_name`), with one of ``suffixes``."""
    plain = is_plain_name(value)
    suffix_ok = not suffixes or Path(value).suffix.lower() in suffixes
    if not (plain and suffix_ok):
        ending = f", ending in {' or '.join(suffixes)}" if suffixes else ""
        raise ScenarioError(f"{origin}: {name} = {value!r} is not valid: {role}, so it must be {NAME_RULE}{ending} "
                            f"(e.g. {example!r})")
    return value


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


def validate(raw: Mapping, origin: str) -> dict:
    """Check sections, keys and types against :data:`SCHEMA`; fill the defaults."""
    sections = [*SCHEMA, "phases", "inequalities"]
    unknown = sorted(set(raw) - set(sections))
    if unknown:
        raise ScenarioError(f"{origin}: unknown section(s) {', '.join(unknown)}; valid: {', '.join(sections)}")
    required = SEQUENCE_REQUIRED_SECTIONS if "phases" in raw else REQUIRED_SECTIONS
    missing = [section for section in required if section not in raw]
    if missing:
        raise ScenarioError(f"{origin}: missing section(s) {', '.join(missing)}")
    skipped = {"trajectory"} if "phases" in raw and "trajectory" not in raw else set()  # a sequence has none
    scenario = {section: validate_table(raw.get(section, {}), keys, section, origin)
                for section, keys in SCHEMA.items() if section not in skipped}
    phases = raw.get("phases", [])
    if not isinstance(phases, list) or not all(isinstance(phase, dict) for phase in phases):
        raise ScenarioError(f"{origin}: phases must be an array of tables ([[phases]])")
    scenario["phases"] = [validate_table(phase, PHASE_SCHEMA, f"phases[{index}]", origin)
                          for index, phase in enumerate(phases)]
    scenario["inequalities"] = check_tables(raw.get("inequalities", []), origin)
    for index, table in enumerate(scenario["inequalities"]):
        check_range(f"inequalities[{index}]", table, origin)
    if scenario["scenario"]["name"]:
        check_name("scenario.name", scenario["scenario"]["name"], origin,
                   "it names the default output folder out/<name>", example="hoang2011_w1")
    if scenario["outputs"]["animation"]:
        check_name("outputs.animation", scenario["outputs"]["animation"], origin,
                   "it names a file inside the output folder", ANIMATION_SUFFIXES, example="grip.gif")
    return scenario


def validate_table(given: Any, keys: Mapping[str, tuple], section: str, origin: str) -> dict:
    """One table against its schema (types, allowed values), defaults filled."""
    if not isinstance(given, dict):
        raise ScenarioError(f"{origin}: [{section}] must be a table")
    unknown = sorted(set(given) - set(keys))
    if unknown:
        raise ScenarioError(f"{origin}: unknown key(s) {', '.join(f'{section}.{k}' for k in unknown)}; "
                            f"valid in [{section}]: {', '.join(keys)}")
    table = {}
    for key, (kinds, default, allowed) in keys.items():
        if key not in given:
            if default is REQUIRED:
                raise ScenarioError(f"{origin}: {section}.{key} is required")
            table[key] = copy.deepcopy(default)
            continue
        table[key] = check_value(f"{section}.{key}", given[key], kinds, allowed, origin)
    return table


def check_value(name: str, value: Any, kinds, allowed, origin: str) -> Any:
    """One value against its type, allowed set and range (:data:`MAX_MAGNITUDE`, :data:`LOWER_BOUNDS`)."""
    if kinds == NUMBERS:
        if not isinstance(value, list) or not all(is_number(v) for v in value):
            raise ScenarioError(f"{origin}: {name} must be a list of numbers, got {value!r}")
        check_range(name, value, origin)
        return [float(v) for v in value]
    kinds = kinds if isinstance(kinds, tuple) else (kinds,)
    if not isinstance(value, kinds) or (isinstance(value, bool) and bool not in kinds):
        raise ScenarioError(f"{origin}: {name} must be {type_names(kinds)}, got {value!r}")
    if isinstance(value, list) and kinds != (list,) and not all(is_number(v) for v in value):
        raise ScenarioError(f"{origin}: {name} must be {type_names(kinds)} of numbers, got {value!r}")
    if name != "model.args":  # xacro args are checked by the model (uvms.model.checks)
        check_range(name, value, origin)
    if allowed is not None and value not in allowed:
        raise ScenarioError(f"{origin}: {name} = {value!r} is not valid; valid: {', '.join(map(repr, allowed))}")
    return value


def is_number(value: Any) -> bool:
    return isinstance(value, NUMBER) and not isinstance(value, bool)


def check_range(name: str, value: Any, origin: str) -> None:
    """Every number in ``value`` (a number, or lists and tables of them) finite, |x| <= MAX_MAGNITUDE, and above
    the lower bound of ``name`` if it has one."""
    if isinstance(value, dict):
        for key, item in value.items():
            check_range(f"{name}.{key}", item, origin)
        return
    if isinstance(value, list):
        for item in value:
            check_range(name, item, origin)
        return
    if not is_number(value):
        return
    shown = (f"{value:.6g}" if isinstance(value, float) or abs(value) < 10**15
             else f"a {len(str(abs(value)))}-digit integer")
    if not (isinstance(value, int) or math.isfinite(value)):
        raise ScenarioError(f"{origin}: {name} must be finite, got {value!r}")
    if abs(value) > MAX_MAGNITUDE:
        raise ScenarioError(f"{origin}: {name} = {shown} is out of range: scenario numbers are SI values with "
                            f"|x| <= {MAX_MAGNITUDE:.0e} (no gain, damping, weight, length, speed or time of a "
                            f"vehicle-manipulator run comes near it, and beyond it the solvers overflow)")
    bound = LOWER_BOUNDS.get(name)
    if bound is not None:
        low, strict, meaning = bound
        if value < low or (strict and value == low):
            raise ScenarioError(f"{origin}: {name} = {shown} is out of range: it is {meaning}, valid: "
                                f"{low:g} {'<' if strict else '<='} {name} <= {MAX_MAGNITUDE:.0e}")


def changed_keys(scenario: dict, section: str, keys: Sequence[str] | None = None) -> list[str]:
    """The keys of ``section`` (all, or ``keys``) whose value differs from the schema's default, in schema order."""
    return [key for key, (_, default, _) in SCHEMA[section].items()
            if (keys is None or key in keys) and scenario[section][key] != default]


def type_names(kinds: tuple) -> str:
    names = {int: "a number", float: "a number", str: "a string", bool: "true/false", list: "a list", dict: "a table"}
    return " or ".join(dict.fromkeys(names[kind] for kind in kinds))
