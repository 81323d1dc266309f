"""Scenarios: one TOML file names a model, a task, a trajectory and a solver; ``run`` computes it.

The schema (sections, keys, types, defaults) is :data:`SCHEMA`; unknown keys
are rejected with the list of valid ones, and ``--set KEY=VALUE`` overrides any
key (dotted path, e.g. ``solver.gain=2`` or ``model.args.l1=0.6``).

By default the motion is integrated kinematically (:mod:`uvms.simulate`). A ``[plant]``
section with ``type = "rigid"`` or ``"hydrodynamic"`` runs the free-floating dynamics of
:mod:`uvms.dynamics.plant` instead, the joints driven by the generalized-Jacobian controller of
:mod:`uvms.control.gjm` (amundsen2018 eq. 4-8; the vehicle passive); both run in the one loop of
:mod:`uvms.simulate` and give one result.
"""

from __future__ import annotations

import contextlib
import copy
import math
import os
import re
import sys
import time
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from . import outputs

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib
from .errors import NumericalError, ScenarioError, UVMSError
from .control.gjm import GJM_KINDS, GJMController, VelocityRamps
from .dynamics.hydrodynamics import HydroParameters
from .model.loader import load
from .dynamics.plant import Plant
from .robot import Robot
from .simulate import SimulationResult, simulate, simulate_gjm, step_count
from .solvers import (
    VariableDamping,
    clik_velocity,
    constrained_velocity,
    initial_configuration,
    priority_velocity,
)
from .control.sequence import METHODS as SEQUENCE_METHODS
from .control.sequence import Phase, PhasePlan, SequenceController, sequence_metrics
from .tasks import FrameTask, JointLimitPotential, VehicleTask
from .trajectory import CirclePath, LinePath, PathTrajectory, PolynomialLaw, SE3Trajectory, TrapezoidLaw

NUMBER = (int, float)
#: [plant] types: the kinematic simulation (the vehicle follows momentum exactly, or is actuated), or the
#: free-floating dynamics of uvms.plant without (rigid) or with (hydrodynamic) the model's hydrodynamics.
PLANT_TYPES = ("kinematic", "rigid", "hydrodynamic")
NUMBERS = "numbers"  # a list of numbers
REQUIRED = object()
#: A name read from a scenario that becomes a file or folder name (``scenario.name`` -> ``out/<name>``,
#: ``outputs.animation``) is a plain name: one path component, never a path that leads outside ``--out``.
NAME_PATTERN = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]{0,127}")
NAME_RULE = ("a plain name: letters, digits, '.', '_' and '-', starting with a letter or a digit, at most 128 "
             "characters, no '/' and no '..'")
ANIMATION_SUFFIXES = (".gif", ".mp4")
#: The largest magnitude of a number in a scenario (SI units; model.args excepted, the model checks them). No
#: gain [1/s], damping, weight, length [m], speed [m/s], time [s] or angle [rad] of a vehicle-manipulator run
#: comes near it, and beyond it products such as damping**2, gain * dt or weight ratios overflow or swamp the
#: double precision of the solvers.
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
    },
    "task": {
        "frame": (str, "", None),
        "frames": (list, [], None),
        "axes": (list, [], None),
        "orientation_error": (str, "log", ("log", "euler")),
    },
    "trajectory": {
        "type": (str, "circle", ("circle", "line", "pose", "ramps")),
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
        "method": (str, "clik", ("clik", "task_priority", "kinematic_constraint")),
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
        "arm": (NUMBERS, [], None),
    },
    "simulation": {
        "dt": (NUMBER, REQUIRED, None),
        "duration": (NUMBER, 0.0, None),
        "integrator": (str, "rk4", ("euler", "rk4")),
    },
    "plant": {
        "type": (str, "kinematic", PLANT_TYPES),
        "gjm": (str, "rigid", GJM_KINDS),
        "motor_time_constant": (NUMBER, 0.1, None),
        "motor_feedforward": (bool, False, None),
        "control_dt": (NUMBER, 0.0, None),
        "gravity": (bool, False, None),
        "added_mass": (bool, None, None),
        "damping": (bool, None, None),
        "current": (NUMBERS, [], None),
    },
    "outputs": {
        "figures": (bool, True, None),
        "animation": (str, "", None),
    },
}
#: keys of one [[phases]] table (a sequence scenario: several frames, no [trajectory]); see uvms.sequence.
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
    """Read, override and validate a scenario file; relative model paths become absolute.

    Raises:
        ScenarioError: unreadable file, bad TOML, unknown key, wrong type, impossible value.
    """
    return scenario_from_raw(read_toml(path), path, overrides)


def read_toml(path: str | os.PathLike) -> dict:
    """The raw table of a scenario file (not validated)."""
    path = Path(path)
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ScenarioError(f"scenario file {str(path)!r} does not exist") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ScenarioError(f"cannot read scenario {str(path)!r}: {exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{path}: invalid TOML ({exc})") from None


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
    scenario["scenario"]["name"] = scenario["scenario"]["name"] or name_from_stem(path.stem)
    return scenario


def name_from_stem(stem: str) -> str:
    """The run name of a scenario without ``scenario.name``: its file name, made a plain name ("my run" -> "my_run")."""
    name = re.sub(r"\.{2,}", ".", re.sub(r"[^A-Za-z0-9._-]+", "_", stem)).lstrip("._-")[:128]
    return name or "scenario"


def check_name(name: str, value: str, origin: str, role: str, suffixes: Sequence[str] = (), example: str = "") -> str:
    """A scenario string that becomes a file name: a plain name (:data:`NAME_PATTERN`), with one of ``suffixes``."""
    plain = NAME_PATTERN.fullmatch(value) is not None and ".." not in value
    suffix_ok = not suffixes or Path(value).suffix.lower() in suffixes
    if not (plain and suffix_ok):
        ending = f", ending in {' or '.join(suffixes)}" if suffixes else ""
        raise ScenarioError(f"{origin}: {name} = {value!r} is not valid: {role}, so it must be {NAME_RULE}{ending} "
                            f"(e.g. {example!r})")
    return value


def parse_value(text: str) -> Any:
    """A --set value as TOML (number, bool, list, quoted string); bare words stay strings."""
    try:
        return tomllib.loads(f"value = {text}")["value"]
    except tomllib.TOMLDecodeError:
        return text


def apply_override(raw: dict, assignment: str) -> None:
    """Apply ``section.key[.sub]=VALUE`` to the raw scenario."""
    key, sep, text = assignment.partition("=")
    parts = key.strip().split(".")
    if not sep or len(parts) < 2 or not all(parts):
        raise ScenarioError(f"--set expects SECTION.KEY=VALUE (e.g. solver.gain=2, model.args.l1=0.6), got {assignment!r}")
    node = raw
    for part in parts[:-1]:
        node = node.setdefault(part, {})
        if not isinstance(node, dict):
            raise ScenarioError(f"--set {key}: {part!r} is not a table")
    node[parts[-1]] = parse_value(text.strip())


def validate(raw: Mapping, origin: str) -> dict:
    """Check sections, keys and types against :data:`SCHEMA`; fill the defaults."""
    sections = [*SCHEMA, "phases"]
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
    if isinstance(value, bool) and bool not in kinds:
        raise ScenarioError(f"{origin}: {name} must be {type_names(kinds)}, got {value!r}")
    if not isinstance(value, kinds):
        raise ScenarioError(f"{origin}: {name} must be {type_names(kinds)}, got {value!r}")
    if isinstance(value, list) and kinds != (list,) and not all(is_number(v) for v in value):
        raise ScenarioError(f"{origin}: {name} must be {type_names(kinds)} of numbers, got {value!r}")
    if name != "model.args":  # xacro args are checked by the model (uvms.checks)
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
    shown = f"{value:.6g}" if isinstance(value, float) or abs(value) < 10**15 else f"a {len(str(abs(value)))}-digit integer"
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


def type_names(kinds: tuple) -> str:
    names = {int: "a number", float: "a number", str: "a string", bool: "true/false", list: "a list", dict: "a table"}
    return " or ".join(dict.fromkeys(names[kind] for kind in kinds))


# ------------------------------------------------------------------ building
@dataclass
class Setup:
    """Everything a run needs, built from a validated scenario."""

    robot: Robot
    task: FrameTask
    trajectory: PathTrajectory | SE3Trajectory
    q0: np.ndarray
    controller: Any
    duration: float
    initial_residual: float
    plan: PhasePlan | None = None  # sequence scenarios only
    plant: Plant | None = None  # [plant] type rigid or hydrodynamic: the controller is a GJMController
    control_dt: float = 0.0  # [s] sampling period of that controller (0: continuous)


def build(scenario: dict) -> Setup:
    """Model, task, initial configuration, trajectory and controller of a scenario."""
    model = scenario["model"]
    robot = load(model["path"], base=model["base"] or None, args=model["args"] or None, ee=model["ee"] or None)
    if scenario["phases"]:
        if scenario["plant"]["type"] != "kinematic":
            raise ScenarioError("a sequence scenario ([[phases]]) runs on the kinematic plant only; "
                                "remove [plant] or set plant.type = 'kinematic'")
        return build_sequence(robot, scenario)
    task_section = scenario["task"]
    task = FrameTask(robot, task_section["frame"] or None, axes=task_section["axes"] or None,
                     orientation=task_section["orientation_error"])
    q0, residual = initial_q(robot, task, scenario)
    trajectory = make_trajectory(robot.fk(q0, task.frame), scenario["trajectory"])
    duration = float(scenario["simulation"]["duration"] or trajectory.duration)
    if scenario["plant"]["type"] != "kinematic":
        plant, controller = make_plant_controller(robot, task, trajectory, scenario)
        return Setup(robot, task, trajectory, q0, controller, duration, residual, plant=plant,
                     control_dt=float(scenario["plant"]["control_dt"]))
    check_kinematic_plant(scenario["plant"])
    controller = make_controller(robot, task, trajectory, scenario)
    return Setup(robot, task, trajectory, q0, controller, duration, residual)


def build_sequence(robot: Robot, scenario: dict) -> Setup:
    """A [[phases]] scenario: several frames, claws and a claw distance, the vehicle held (uvms.sequence)."""
    solver, frames = scenario["solver"], scenario["task"]["frames"] or robot.ee_frames
    if solver["method"] not in SEQUENCE_METHODS:
        raise ScenarioError(f"a sequence scenario needs solver.method in {', '.join(SEQUENCE_METHODS)}, "
                            f"got {solver['method']!r}")
    if scenario["initial"]["method"] != "given" or not isinstance(solver["gain"], NUMBER):
        raise ScenarioError("a sequence scenario needs initial.method = 'given' and one number for solver.gain")
    q0, _ = initial_q(robot, None, scenario)
    phases = [Phase(name=phase["name"] or f"phase {index + 1}", duration=float(phase["duration"]),
                    offsets=phase["offsets"], joints=phase["joints"], distance=phase["distance"])
              for index, phase in enumerate(scenario["phases"])]
    plan = PhasePlan(robot, q0, frames, phases)
    controller = SequenceController(robot, plan, method=solver["method"], gain=float(solver["gain"]),
                                    damping=float(solver["damping"]), priority=solver["priority"],
                                    hold_vehicle=scenario["vehicle"]["hold"])
    duration = scenario["simulation"]["duration"] or plan.duration
    return Setup(robot, controller.frame_tasks[0], plan.frame_trajectory(frames[0]), q0, controller, float(duration),
                 0.0, plan)


def initial_q(robot: Robot, task: FrameTask | None, scenario: dict) -> tuple[np.ndarray, float]:
    """q0 as given, or optimized (hoang2011 sec. 2.3) to put the frame at the trajectory start."""
    initial = scenario["initial"]
    base = initial["base"] or None
    arm = initial["arm"] or None
    try:
        q_given = robot.configuration(base=np.array(base) if base else None, arm=np.array(arm) if arm else None)
    except UVMSError as exc:
        raise ScenarioError(f"initial.base/initial.arm: {exc}") from None
    if initial["method"] == "given":
        return q_given, 0.0
    trajectory = scenario["trajectory"]
    if not trajectory["start"] or not trajectory["orientation"]:
        raise ScenarioError("initial.method = 'optimize' needs trajectory.start and trajectory.orientation")
    task.set_target(np.concatenate([trajectory["start"], trajectory["orientation"]]))
    potential = JointLimitPotential(robot, weights=np.asarray(scenario["solver"]["joint_limit_weights"], dtype=float))
    result = initial_configuration(robot, task, potential, q_given)
    if not result.success:
        raise ScenarioError(f"no initial configuration reaches the trajectory start (residual {result.residual:.3g})")
    return result.q, result.residual


def vector(values: list[float], size: int, name: str) -> np.ndarray:
    if len(values) != size:
        raise ScenarioError(f"trajectory.{name} must have {size} numbers, got {len(values)}")
    return np.array(values, dtype=float)


def make_trajectory(start_pose: pin.SE3, section: dict) -> PathTrajectory | SE3Trajectory | VelocityRamps:
    """The desired end-effector motion; start and orientation default to the frame's initial pose."""
    start = vector(section["start"], 3, "start") if section["start"] else start_pose.translation.copy()
    orientation = (vector(section["orientation"], 3, "orientation") if section["orientation"]
                   else pin.rpy.matrixToRpy(start_pose.rotation))
    kind = section["type"]
    if kind == "ramps":
        if not section["velocity"]:
            raise ScenarioError("a ramps trajectory needs trajectory.velocity (the cruise velocity [m/s], world axes)")
        if not 0 < section["accel_time"] <= section["duration"] / 2:
            raise ScenarioError(f"a ramps trajectory needs trajectory.accel_time (the ramp time) in (0, duration/2] = "
                                f"(0, {section['duration'] / 2:g}] s, got {section['accel_time']:g}")
        return VelocityRamps.trapezoid(start, vector(section["velocity"], 3, "velocity"), section["duration"],
                                       section["accel_time"], rotation=pin.rpy.rpyToMatrix(*orientation))
    if kind == "circle":
        if section["center"]:
            center = vector(section["center"], 3, "center")
        elif section["center_offset"]:
            center = start + vector(section["center_offset"], 3, "center_offset")
        else:
            raise ScenarioError("a circle trajectory needs trajectory.center or trajectory.center_offset")
        path = CirclePath(center, start, vector(section["normal"], 3, "normal"))
    else:
        if section["end"]:
            end = vector(section["end"], 3, "end")
        elif section["end_offset"]:
            end = start + vector(section["end_offset"], 3, "end_offset")
        else:
            raise ScenarioError(f"a {kind} trajectory needs trajectory.end or trajectory.end_offset")
        path = LinePath(start, end)
    law = make_law(section, path.length)
    if kind == "pose":
        end_orientation = (vector(section["end_orientation"], 3, "end_orientation") if section["end_orientation"]
                           else orientation)
        return SE3Trajectory(np.concatenate([start, orientation]), np.concatenate([path(path.length).point, end_orientation]),
                             law)
    return PathTrajectory(path, law, orientation)


def make_law(section: dict, path_length: float):
    """Time law: trapezoid from a speed, or any law from laps (circle) / the path length."""
    duration, accel_time = section["duration"], section["accel_time"]
    distance = section["laps"] * path_length if section["laps"] else path_length
    if section["law"] == "trapezoid":
        if section["speed"]:
            return TrapezoidLaw(speed=section["speed"], duration=duration, accel_time=accel_time)
        return TrapezoidLaw.from_distance(distance, duration, accel_time)
    return PolynomialLaw(distance=distance, duration=duration, degree=3 if section["law"] == "cubic" else 5)


def check_kinematic_plant(section: dict) -> None:
    """Reject [plant] keys that only a dynamic plant uses when plant.type = 'kinematic'."""
    defaults = {key: default for key, (_, default, _) in SCHEMA["plant"].items()}
    unused = [key for key in ("gjm", "motor_feedforward", "control_dt", "gravity", "added_mass", "damping", "current")
              if section[key] != defaults[key]]
    if unused:
        raise ScenarioError(f"plant.{unused[0]} needs a dynamic plant: the kinematic one moves the vehicle by momentum "
                            f"conservation (solver.free_floating) or as commanded; set plant.type = 'rigid' or "
                            f"'hydrodynamic'")


def make_plant(robot: Robot, section: dict) -> Plant:
    """The free-floating plant of a [plant] section (type rigid or hydrodynamic)."""
    tau = float(section["motor_time_constant"])
    if not tau > 0:
        raise ScenarioError(f"plant.motor_time_constant must be > 0 s (the joint servos' time constant), got {tau:g}")
    current = None
    if section["current"]:
        if len(section["current"]) != 3:
            raise ScenarioError(f"plant.current must have 3 numbers (world ENU [m/s]), got {len(section['current'])}")
        current = np.array(section["current"], dtype=float)
    if robot.base_type == "fixed":
        raise ScenarioError(f"plant.type = {section['type']!r} needs a floating or planar vehicle; "
                            f"{robot.name} has a fixed base (set model.base or use plant.type = 'kinematic')")
    if section["type"] == "rigid":
        for key in ("added_mass", "damping"):
            if section[key]:
                raise ScenarioError(f"plant.{key} = true needs plant.type = 'hydrodynamic'; a rigid plant has no fluid")
        if section["gravity"] or current is not None:
            raise ScenarioError("plant.gravity and plant.current need plant.type = 'hydrodynamic' (buoyancy, fluid); "
                                "a rigid plant floats weightless in vacuum")
        return Plant(robot, HydroParameters(source="rigid plant (no fluid)"), gravity=False, motor_time_constant=tau,
                     added_mass=False, damping=False)
    added_mass = True if section["added_mass"] is None else section["added_mass"]
    damping = True if section["damping"] is None else section["damping"]
    plant = Plant(robot, None, gravity=section["gravity"], motor_time_constant=tau, current=current,
                  added_mass=added_mass, damping=damping)
    if not plant.links:
        raise ScenarioError(f"plant.type = 'hydrodynamic' needs hydrodynamic parameters, and {robot.source} has none; "
                            f"add a uuv_simulator block or hydrodynamics.yaml (see uvms.hydrodynamics), "
                            f"or use plant.type = 'rigid'")
    return plant


def make_plant_controller(robot: Robot, task: FrameTask, trajectory, scenario: dict) -> tuple[Plant, GJMController]:
    """The plant and the GJM controller of amundsen2018 (eq. 4-8) for a dynamic [plant]."""
    section, solver = scenario["plant"], scenario["solver"]
    if solver["method"] != "clik" or not solver["free_floating"]:
        raise ScenarioError(f"plant.type = {section['type']!r} leaves the vehicle passive: it needs solver.method = "
                            f"'clik' and solver.free_floating = true (the joints are commanded through the "
                            f"generalized Jacobian, plant.gjm)")
    if solver["alpha"] or solver["enforce_limits"]:
        raise ScenarioError("solver.alpha and solver.enforce_limits are not supported with a dynamic plant "
                            "(the GJM controller of amundsen2018 has no null-space term or joint clamping)")
    plant = make_plant(robot, section)
    gain = np.asarray(solver["gain"], dtype=float)
    if gain.shape not in ((), (3,)):
        raise ScenarioError(f"solver.gain with a dynamic plant is K on the position error: one number or 3 "
                            f"(x, y, z) [1/s], got {solver['gain']!r}")
    damping: float | VariableDamping = solver["damping"]
    if solver["damping_epsilon"] > 0:
        damping = VariableDamping(solver["damping_epsilon"], solver["damping_max"])
    weights = np.asarray(solver["weights"], dtype=float) if solver["weights"] else None
    control_dt, dt = float(section["control_dt"]), float(scenario["simulation"]["dt"])
    ratio = control_dt / dt
    if control_dt < 0 or (control_dt > 0 and (ratio < 1 - 1e-9 or abs(ratio - round(ratio)) > 1e-6)):
        raise ScenarioError(f"plant.control_dt must be 0 (continuous controller) or a multiple of simulation.dt = "
                            f"{dt:g} s, got {control_dt:g}")
    try:
        controller = GJMController(robot, trajectory, frame=task.frame, axes=task.axes, gain=gain, damping=damping,
                                   weights=weights, gjm=section["gjm"], hydro=plant.hydro if plant.links else None,
                                   motor_feedforward=plant.motor_time_constant if section["motor_feedforward"] else 0.0)
    except UVMSError as exc:
        raise ScenarioError(f"plant/solver: {exc}") from None
    return plant, controller


def make_controller(robot: Robot, task: FrameTask, trajectory, scenario: dict):
    """(q, t) -> (v, diagnostics) for the scenario's solver method."""
    solver, vehicle = scenario["solver"], scenario["vehicle"]
    dt = scenario["simulation"]["dt"]
    gain = np.asarray(solver["gain"], dtype=float)
    damping: float | VariableDamping = solver["damping"]
    if solver["damping_epsilon"] > 0:
        damping = VariableDamping(solver["damping_epsilon"], solver["damping_max"])
    potential = JointLimitPotential(robot, weights=np.asarray(solver["joint_limit_weights"], dtype=float))
    weights = np.asarray(solver["weights"], dtype=float) if solver["weights"] else None
    method = solver["method"]
    vehicle_task = None
    if method != "clik":
        if not vehicle["velocities"] and vehicle["heading"] is None and vehicle["depth"] is None:
            raise ScenarioError(f"solver.method = {method!r} needs a [vehicle] task (velocities, heading or depth)")
        vehicle_task = VehicleTask(robot, velocities=vehicle["velocities"], heading=vehicle["heading"],
                                   depth=vehicle["depth"])

    def follow(t: float) -> None:
        sample = trajectory(t)
        task.set_target(sample.pose)
        task.set_target_velocity(sample.twist)

    def controller(q: np.ndarray, t: float):
        follow(t)
        if method == "clik":
            result = clik_velocity(robot, q, task, gain=gain, weights=weights, damping=damping, potential=potential,
                                   alpha=solver["alpha"], free_floating=solver["free_floating"], dt=dt,
                                   enforce_limits=solver["enforce_limits"])
        elif method == "task_priority":
            result = priority_velocity(robot, q, [task, vehicle_task], gain=[gain, vehicle["gain"]],
                                       method=solver["priority"], damping=float(solver["damping"]))
        else:
            result = constrained_velocity(robot, q, task, vehicle_task, gain=gain, constraint_gain=vehicle["gain"])
        return result.v, result

    return controller


# ------------------------------------------------------------------ running
@dataclass
class RunResult:
    """A scenario run: its simulation, metrics and the files written."""

    scenario: dict
    setup: Setup
    simulation: SimulationResult
    metrics: dict
    files: list[Path]
    plant_run: SimulationResult | None = None  # dynamic [plant] only: the same run (its plant series filled)

def compute_metrics(result: SimulationResult, setup: Setup, wall_time: float) -> dict:
    """The numbers of ``metrics.json``."""
    robot = result.robot
    arm = result.arm()
    lower, upper = robot.arm_limits
    violation = np.maximum(np.maximum(lower - arm, arm - upper), 0.0)
    metrics = {
        "max_position_error": float(result.position_error.max()),
        "max_orientation_error": float(result.orientation_error.max()),
        "final_position_error": float(result.position_error[-1]),
        "rms_position_error": float(np.sqrt(np.mean(result.position_error**2))),
        "max_joint_limit_violation": float(np.nan_to_num(violation, nan=0.0).max(initial=0.0)),
        "arm_travel": float(np.abs(np.diff(arm, axis=0)).sum()),
        "steps": int(len(result.t) - 1),
        "wall_time": float(wall_time),
        "initial_configuration": setup.q0.tolist(),
        "initial_residual": float(setup.initial_residual),
        "min_sigma_min": float(result.sigma_min.min()),
        "max_damping": float(result.damping.max()),
    }
    if robot.base_type != "fixed":
        vehicle = result.vehicle_pose()
        position = vehicle[:, :2] if robot.base_type == "planar" else vehicle[:, :3]
        yaw = vehicle[:, -1]  # unwrapped
        metrics["vehicle_travel"] = float(np.linalg.norm(np.diff(position, axis=0), axis=1).sum())
        metrics["vehicle_yaw_range"] = float(yaw.max() - yaw.min())
    else:
        metrics["vehicle_travel"] = 0.0
        metrics["vehicle_yaw_range"] = 0.0
    if setup.plan is not None:
        metrics.update(sequence_metrics(robot, setup.plan, result.t, result.q))
    return metrics


def run(
    scenario_path: str | os.PathLike,
    out: str | os.PathLike | None = None,
    overrides: Sequence[str] = (),
    progress: bool | None = None,
    *,
    lock: bool = True,
) -> RunResult:
    """Run a scenario file and write ``metrics.json``, ``trajectory.csv``/``.npz`` and figures into ``out``.

    With a dynamic ``[plant]`` (rigid or hydrodynamic) the joints are driven by the GJM
    controller of :mod:`uvms.control.gjm` through :func:`uvms.simulate.simulate_gjm` (the one loop), and
    ``plant.npz`` (commands, torques, energy, momentum) and the figures of
    :func:`uvms.viz.plotting.gjm_figures` are added.

    The scenario is read, checked and built (model, initial configuration, step count) before anything is
    written; then every file goes into a temporary folder that replaces ``out`` as a whole at the end
    (:func:`uvms.outputs.run_folder`): ``out`` holds the previous complete run until the new one is complete.

    Args:
        scenario_path: the TOML file.
        out: output folder (default ``out/<scenario name>``).
        overrides: ``SECTION.KEY=VALUE`` strings.
        progress: progress bar (None: on a terminal only).
        lock: hold the lock of ``out`` (False only for a folder inside another run folder, as the points of
            :func:`uvms.sweep.sweep`).

    Raises:
        ScenarioError: a bad scenario or override; StepCountError: no step or too many steps;
        NumericalError: the numerics overflowed; RunFolderBusy: another uvms process writes ``out``.
    """
    scenario = read_scenario(scenario_path, overrides)
    name = scenario["scenario"]["name"]
    out = Path(out) if out is not None else Path("out") / name
    started = time.perf_counter()
    with numerics_guard(name):
        setup = build(scenario)
    check_step_count(scenario, setup.duration)
    with outputs.run_folder(out, lock=lock) as folder, numerics_guard(name):
        result = execute(scenario, setup, folder, progress, started)
    result.files = [out / path.relative_to(folder) for path in result.files]
    return result


@contextlib.contextmanager
def numerics_guard(name: str) -> Iterator[None]:
    """Turn an arithmetic failure escaping from the numerics (overflow, singular matrix...) into a NumericalError."""
    try:
        yield
    except (ArithmeticError, np.linalg.LinAlgError) as exc:
        message = " ".join(str(exc).split())
        raise NumericalError(f"scenario {name!r}: the numerics failed ({type(exc).__name__}"
                             f"{': ' + message if message else ''}); a number of the scenario (gain, damping, "
                             f"weight, dt, a model dimension) is too large or too small for the solvers") from exc


def check_step_count(scenario: dict, duration: float) -> int:
    """The number of steps of a run, checked before it starts (:func:`uvms.simulate.step_count`)."""
    if scenario["simulation"]["duration"]:
        duration_name = "simulation.duration"
    else:
        duration_name = "the phases' durations" if scenario["phases"] else "trajectory.duration"
    return step_count(duration, float(scenario["simulation"]["dt"]), dt_name="simulation.dt",
                      duration_name=duration_name)


def execute(scenario: dict, setup: Setup, folder: Path, progress: bool | None, started: float) -> RunResult:
    """Simulate a built scenario and write its files into ``folder``."""
    simulation_section = scenario["simulation"]
    plant_run: SimulationResult | None = None
    if setup.plant is not None:
        result = plant_run = simulate_gjm(setup.plant, setup.controller, setup.q0, setup.duration,
                                          simulation_section["dt"], control_dt=setup.control_dt,
                                          integrator=simulation_section["integrator"], progress=progress,
                                          task=setup.task)
    else:
        result = simulate(setup.robot, setup.controller, setup.q0, duration=setup.duration,
                          dt=simulation_section["dt"], task=setup.task, desired=lambda t: setup.trajectory(t).pose,
                          integrator=simulation_section["integrator"], progress=progress)
    metrics = compute_metrics(result, setup, time.perf_counter() - started)
    metrics["scenario"] = scenario["scenario"]["name"]
    if plant_run is not None:
        metrics.update(plant=scenario["plant"]["type"], gjm=scenario["plant"]["gjm"],
                       motor_feedforward=scenario["plant"]["motor_feedforward"], **plant_run.plant_metrics())
    files = list(result.save(folder))
    if plant_run is not None:
        outputs.write_npz(folder / "plant.npz", **plant_run.plant_arrays())
        files.append(folder / "plant.npz")
    if scenario["outputs"]["figures"]:
        from .viz.plotting import scenario_figures  # matplotlib only when figures are asked for

        files += scenario_figures(result, setup.trajectory, folder, title=scenario["scenario"]["name"])
        if plant_run is not None:
            from .viz.plotting import gjm_figures

            files += gjm_figures(plant_run, folder, title=scenario["scenario"]["name"])
        if setup.plan is not None:
            from .viz.plotting import sequence_figures

            files += sequence_figures(result, setup.plan, folder, title=scenario["scenario"]["name"],
                                      animation=scenario["outputs"]["animation"], progress=progress)
    outputs.write_json(folder / "metrics.json", metrics)
    files.append(folder / "metrics.json")
    return RunResult(scenario=scenario, setup=setup, simulation=result, metrics=metrics, files=files,
                     plant_run=plant_run)
