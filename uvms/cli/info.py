"""``uvms info``: a model named on the command line (``--arg NAME=VALUE``) and the text that describes it."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from ..errors import UVMSError
from ..model.resources import MAX_YAML_BYTES, read_text
from ..robot.configuration import Configuration
from ..robot.robot import Robot
from .terminal import say


def parse_assignments(items: Sequence[str] | None) -> dict[str, str]:
    """``["NAME=VALUE", ...]`` -> {NAME: VALUE}."""
    assignments: dict[str, str] = {}
    for item in items or ():
        name, sep, value = item.partition("=")
        if not sep or not name:
            raise UVMSError(f"--arg expects NAME=VALUE, got {item!r}")
        assignments[name] = value
    return assignments


def parse_arm_joints(items: Sequence[str] | None) -> list[str] | None:
    """``--arm-joints`` values (repeatable, each one name or names separated by commas) -> the joint names, [] for
    ``--arm-joints ""`` (every joint frozen), None when not given (:func:`uvms.load`'s rule)."""
    if items is None:
        return None
    return [name.strip() for item in items for name in item.split(",") if name.strip()]


def command_model(options: argparse.Namespace) -> Robot:
    """The model of ``uvms info``, ``uvms view`` and ``uvms workspace``: a model file, a shipped name or a scenario
    ``.toml`` (its ``[model]``), with ``--base``, ``--arg``, ``--ee``, ``--arm-joints`` and ``--package-path``
    (:func:`uvms.scenario.record.named_model`, which loads it as :func:`uvms.load` does)."""
    from ..scenario.record import named_model

    return named_model(options.model, parse_assignments(options.arg), options.base, options.package_path,
                       options.ee, parse_arm_joints(options.arm_joints))


def format_limits(lower: np.ndarray, upper: np.ndarray) -> str:
    """Limits of a joint as '[lo, hi]' with unbounded parts shown as '-'."""
    if lower.size != 1 or not (np.isfinite(lower[0]) and np.isfinite(upper[0])) or abs(lower[0]) > 1e30:
        return "-"
    return f"[{lower[0]:+.4f}, {upper[0]:+.4f}]"


#: The top comment lines of a hydrodynamics YAML shown (uvms identify writes two).
MAX_NOTE_LINES = 4
#: The groups of ``uvms info``: joint class -> what the group is.
JOINT_GROUPS = {
    "arm": ("arm joints", "what a user commands"),
    "mimic": ("mimics", "follow an arm joint, no degree of freedom of their own"),
    "propeller": ("propellers", "carry a thruster; frozen (their spin changes no kinematics)"),
    "fin": ("fins", ("control surfaces turned by a fin plugin; frozen in the kinematics, their angle an actuator "
                     "of the actuated plant (lift and drag with the vehicle's speed)")),
    "sensor": ("sensors", "sensor mounts; frozen"),
    "fixed by range": ("fixed by range", "no motion between their limits; frozen"),
    "frozen": ("frozen", "left out of arm_joints"),
}


def describe(robot: Robot, hydrodynamics: str | None = None) -> str:
    """The text of ``uvms info``: joints, DOF split, why the base is what it is, each joint's class and why, frames,
    mass, end-effector poses and the rule that chose them, thrusters, and the hydrodynamics (the model's, or those of
    the YAML file ``hydrodynamics``) with where they come from."""
    lines = [
        f"model       {robot.name}  ({robot.source})",
        f"base        {robot.base_type}: vehicle DOF {robot.n_vehicle}, arm DOF {robot.n_arm} "
        f"(nq {robot.nq}, nv {robot.nv})",
        f"base rule   {robot.base_reason}",
        f"total mass  {robot.total_mass:.3f} kg",
        *joint_table(robot),
        *joint_groups(robot),
        *ignored_limit_lines(robot),
    ]
    body_frames = [f.name for f in robot.model.frames if f.type == pin.FrameType.BODY]
    lines.append(f"frames      {', '.join(body_frames)}")
    neutral = Configuration(robot, robot.neutral())
    lines.append("end effectors at the neutral configuration (world frame, m / rad)")
    width = max([22, *map(len, robot.ee_frames)])
    for frame in robot.ee_frames:
        pose = neutral.pose(robot.frame_id(frame))
        rpy = pin.rpy.matrixToRpy(pose.rotation)
        lines.append(f"  {frame:<{width}} xyz {np.array2string(pose.translation, precision=4, suppress_small=True)}"
                     f"  rpy {np.array2string(rpy, precision=4, suppress_small=True)}")
    lines.append(f"ee rule     {robot.ee_reason}")
    lines += thruster_lines(robot) + hydrodynamics_lines(robot, hydrodynamics)
    lines.append("checks      passed (unit axes, finite numbers, positive "
                 "masses, inertias and geometry sizes, one tree, "
                 "base)")
    return "\n".join(lines)


def joint_table(robot: Robot) -> list[str]:
    """The joints of the model (vehicle, arm, mimics) with their sizes and limits, columns as wide as the names."""
    kinds = [joint.kind.removeprefix("JointModel") + (" (vehicle)" if joint.is_vehicle else
                                                       f" ({robot.joint_classes[joint.name].kind})")
             for joint in robot.joints]
    name_width = max([24, *(len(joint.name) for joint in robot.joints)])
    kind_width = max([27, *map(len, kinds)])
    lines = ["joints", f"  {'name':<{name_width}} {'type':<{kind_width}} {'nq':>2} {'nv':>2}  limits [rad or m]"]
    for joint, kind in zip(robot.joints, kinds):
        lines.append(f"  {joint.name:<{name_width}} {kind:<{kind_width}} {joint.nq:>2} {joint.nv:>2}  "
                     f"{format_limits(joint.lower, joint.upper)}")
    return lines


def joint_groups(robot: Robot) -> list[str]:
    """The model file's joints by class (:data:`JOINT_GROUPS`), each with the reason it was classed so."""
    lines = []
    width = max([24, *map(len, robot.joint_classes)])
    for kind, (title, meaning) in JOINT_GROUPS.items():
        members = [(name, joint_class.reason) for name, joint_class in robot.joint_classes.items()
                   if joint_class.kind == kind]
        if members:
            lines.append(f"{title} ({len(members)}): {meaning}")
            lines.extend(f"  {name:<{width}} {reason}" for name, reason in members)
    return lines


def ignored_limit_lines(robot: Robot) -> list[str]:
    """A line per arm joint of type continuous whose ``<limit>`` writes a lower or upper bound: URDF gives a
    continuous joint no position limits (urdfdom and Pinocchio ignore them), which is right but silent."""
    if robot.urdf_root is None:
        return []
    lines = []
    for joint in robot.urdf_root.iter("joint"):
        name, limit = joint.get("name", ""), joint.find("limit")
        joint_class = robot.joint_classes.get(name)
        if (joint.get("type") != "continuous" or limit is None or joint_class is None or joint_class.kind != "arm"
                or (limit.get("lower") is None and limit.get("upper") is None)):
            continue
        written = f"[{float(limit.get('lower', '0')):g}, {float(limit.get('upper', '0')):g}]"  # checked numbers
        lines.append(f"limits      {name}: continuous, so its written limits {written} are ignored (a continuous "
                     f"joint turns without position limits; its velocity and effort limits are kept); make it "
                     f"revolute to keep them")
    return lines


def vector(values: Sequence[float], style: str = "+.3f") -> str:
    """Numbers as ``[a b c]`` in one format (fixed decimals for positions, significant digits for data)."""
    return "[" + " ".join(f"{value + 0.0:{style}}" for value in values) + "]"  # + 0.0: no -0


def thruster_lines(robot: Robot) -> list[str]:
    """The thrusters (``uvms.dynamics.thrusters_of``): placement and direction in the base frame, limits, lag."""
    from ..dynamics.thrusters.allocation import ThrustAllocator
    from ..dynamics.thrusters.fin_allocation import FinAllocator
    from ..dynamics.thrusters.thrusters import allocation_matrix, thruster_rows, thrusters_of
    from .info_fins import fin_lines

    try:
        thrusters = thrusters_of(robot, required=False)
        rows = thruster_rows(robot, thrusters) if len(thrusters) else []
    except UVMSError as exc:  # info describes the model; the data's problem is stated, not fatal
        return [f"thrusters   not usable: {' '.join(str(exc).split())}"]
    if not rows:
        return ["thrusters   none (no thruster plugin of uuv_simulator, Gazebo Sim or HippoCampus, no thrusters.yaml "
                "beside the model)"]
    width = max([12, *(len(row["name"]) for row in rows)])
    lines = [f"thrusters ({len(rows)}) from {thrusters.source}: position [m], direction (base frame), thrust [N], "
             "time constant [s]"]
    lines += [f"  {row['name']:<{width}} xyz {vector(row['position'])}  dir {vector(row['direction'])}  "
              f"[{-row['max_reverse']:g}, {row['max_forward']:g}]  {row['time_constant']:g}" for row in rows]
    fins, fin_data = fin_lines(robot)
    matrix = allocation_matrix(robot, thrusters)
    allocator = FinAllocator(matrix, thrusters.lower, thrusters.upper, fin_data) if len(fin_data) \
        else ThrustAllocator(matrix, thrusters.lower, thrusters.upper)
    lines += [*fins, f"allocation  {allocator.reach_note(thrusters.names) or 'every body-wrench direction (rank 6)'}"]
    return lines


def hydrodynamics_lines(robot: Robot, path: str | None = None) -> list[str]:
    """Per link the hydrodynamic data (``uvms.dynamics.hydrodynamics_of``, of the YAML file ``path`` when given),
    FLU axes, order [u v w p q r], after where they come from.

    Raises:
        UVMSError: the file ``path`` the user named cannot be read or is invalid (the model's own data's problem
            is a line of the description instead: info describes the model).
    """
    from ..dynamics.hydro.hydrodynamics import hydrodynamics_of
    from ..dynamics.hydro.parameters import hydro_rows

    try:
        hydro = hydrodynamics_of(robot, path, required=False)
    except UVMSError as exc:
        if path is not None:
            raise
        return [f"hydrodynamics not usable: {' '.join(str(exc).split())}"]
    rows = hydro_rows(hydro)
    if not rows:
        return ["hydrodynamics none (no hydrodynamic plugin of uuv_simulator, Gazebo Sim or HippoCampus, no "
                "hydrodynamics.yaml beside the model)"]
    lines = [f"hydrodynamics ({len(rows)} links, rho {hydro.fluid_density:g} kg/m^3): volume [m^3], centre of "
             "buoyancy [m], diagonals of added mass [kg, kg m^2], linear [N s/m, N m s] and quadratic damping "
             "[N s^2/m^2, N m s^2]", *hydrodynamics_source(robot, hydro.source)]
    for row in rows:
        lines += [f"  {row['link']}: V {row['volume']:.4g}  CoB {vector(row['center_of_buoyancy'])}",
                  f"    added mass {vector(row['added_mass_diagonal'], '.4g')}",
                  f"    linear {vector(row['linear_damping'], '.4g')}  "
                  f"quadratic {vector(row['quadratic_damping'], '.4g')}"]
        if any(row["linear_damping_forward_speed"]):
            lines.append(f"    linear per m/s of forward speed {vector(row['linear_damping_forward_speed'], '.4g')}")
    return lines


def hydrodynamics_source(robot: Robot, source: str) -> list[str]:
    """Where the hydrodynamics come from: the model's plugin blocks (of which simulators), or a YAML file with the
    ``#`` lines at its top (``uvms identify`` writes there what it was identified from)."""
    from ..model.plugins import simulators

    if source == robot.source:
        names = [f"{name} {role}" for role in ("hydrodynamics", "buoyancy")
                 for name in simulators(robot.urdf_root, role)] if robot.urdf_root is not None else []
        return [f"  from the {', '.join(names) or 'hydrodynamic'} plugin blocks of {source}"]
    lines = [f"  from {source}"]
    try:
        text = read_text(source, "hydrodynamics", MAX_YAML_BYTES)
    except UVMSError:  # it was just read: only a file replaced since then fails here
        return lines
    for line in text.splitlines()[:MAX_NOTE_LINES]:
        if not line.startswith("#"):
            break
        lines.append(f"  note: {line.lstrip('# ')}")
    return lines


def command_info(options: argparse.Namespace) -> int:
    """``uvms info MODEL``: load the model (running its checks) and describe it."""
    robot = command_model(options)
    say(describe(robot, options.hydrodynamics), sys.stdout, lines=True)
    return 0
