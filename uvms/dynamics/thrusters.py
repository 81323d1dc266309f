"""Thrusters of a vehicle as model data: a frame, thrust limits and a first-order time constant each.

A thruster is a frame of the model: its x axis is the direction of positive thrust and its origin
the point where the thrust acts. It pushes with f in [-max_reverse, +max_forward] [N] and follows
its command through a first-order lag f' = (f_cmd - f) / time_constant.

Where they come from
====================
A ``thrusters.yaml`` beside the model (like ``hydrodynamics.yaml``)::

    time_constant: 0.1            # optional default for every thruster [s]
    max_forward: 51.5             # optional default [N], > 0
    max_reverse: 40.2             # optional default [N], >= 0 (a positive number)
    thrusters:
      thruster_1:                 # a name of your choice
        parent: base_link         # a frame of the model the thruster is fixed to
        xyz: [0.14, -0.092, 0.0]  # [m] origin in the parent frame (default 0)
        rpy: [0.0, 0.0, -2.356]   # [rad] thrust = x axis of Rz Ry Rx (default 0) ...
        direction: [-1, -1, 0]    # ... or the thrust direction itself, in the parent frame
        max_forward: 51.5         # per-thruster values win over the defaults
      thruster_2:
        frame: thruster_2_link    # or a frame of the model (e.g. a fixed link added in the xacro): its x axis

or, in the URDF, uuv_simulator's thruster plugin (one per thruster)::

    <gazebo>
      <plugin name="thruster_1" filename="libuuv_thruster_ros_plugin.so">
        <linkName>thruster_1</linkName>       <!-- a link of the model: thrust along its x axis -->
        <jointName>thruster_1_joint</jointName> <!-- optional: thrust along this joint's axis -->
        <thrustMin>-40.2</thrustMin> <thrustMax>51.5</thrustMax>       <!-- [N] -->
        <dynamics><type>FirstOrder</type><timeConstant>0.1</timeConstant></dynamics>
      </plugin>
    </gazebo>

A thruster must be fixed to the vehicle body (it may not ride on an arm link): its placement in the
vehicle's base frame is then constant, and so is the allocation matrix (:func:`allocation_matrix`).
"""

from __future__ import annotations

import difflib
import os
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from ..errors import ModelCheckError, ModelParseError, UVMSError
from ..model.joint_classes import is_thruster_plugin
from ..model.resources import read_yaml

if TYPE_CHECKING:
    from ..robot.robot import Robot

#: Name of the YAML file looked for beside a model.
YAML_NAME = "thrusters.yaml"
#: How one thruster is written, quoted by every error about thruster data.
VALID_FORM = ("a thruster is {frame: FRAME} or {parent: FRAME, xyz: [x, y, z] m, rpy: [r, p, y] rad or direction: "
              "[dx, dy, dz] (not zero)}, with max_forward > 0 N, max_reverse >= 0 N (a positive number) and "
              "time_constant > 0 s (each given per thruster or as a file default)")
THRUSTER_KEYS = ("frame", "parent", "xyz", "rpy", "direction", "max_forward", "max_reverse", "time_constant")
TOP_KEYS = ("thrusters", "max_forward", "max_reverse", "time_constant")


@dataclass(frozen=True)
class Thruster:
    """One thruster: where it pushes, along what, how hard and how fast.

    Attributes:
        name: its name (YAML key or plugin name).
        parent: the model frame it is fixed to.
        position: (3,) [m] point of application in the parent frame.
        direction: (3,) unit thrust direction in the parent frame.
        max_forward: largest positive thrust [N] (> 0).
        max_reverse: largest reverse thrust [N], a positive number (>= 0): f >= -max_reverse.
        time_constant: tau [s] (> 0) of the first-order response f' = (f_cmd - f) / tau.
    """

    name: str
    parent: str
    position: np.ndarray
    direction: np.ndarray
    max_forward: float
    max_reverse: float
    time_constant: float


@dataclass(frozen=True)
class Thrusters:
    """The thrusters of a vehicle, in order (the order of thrust vectors f (n,)).

    Attributes:
        items: the thrusters; source: where they were read (for messages).
    """

    items: tuple[Thruster, ...]
    source: str = "<none>"

    def __len__(self) -> int:
        return len(self.items)

    @property
    def names(self) -> list[str]:
        """Thruster names, in order."""
        return [thruster.name for thruster in self.items]

    @property
    def lower(self) -> np.ndarray:
        """(n,) lower thrust bounds -max_reverse [N]."""
        return np.array([-thruster.max_reverse for thruster in self.items])

    @property
    def upper(self) -> np.ndarray:
        """(n,) upper thrust bounds max_forward [N]."""
        return np.array([thruster.max_forward for thruster in self.items])

    @property
    def time_constants(self) -> np.ndarray:
        """(n,) first-order time constants [s]."""
        return np.array([thruster.time_constant for thruster in self.items])


# ------------------------------------------------------------------ checks shared by both forms
def _fail(where: str, problem: str) -> ModelCheckError:
    return ModelCheckError(f"{where}: {problem}; {VALID_FORM}")


def _vector(value: object, what: str, where: str) -> np.ndarray:
    """Three finite numbers from a list or from text ("1 0 0")."""
    try:
        array = np.array([float(x) for x in value.split()] if isinstance(value, str) else value, dtype=float).ravel()
    except (TypeError, ValueError):
        raise _fail(where, f"{what} must be 3 numbers, got {value!r}") from None
    if array.shape != (3,) or not np.all(np.isfinite(array)):
        raise _fail(where, f"{what} must be 3 finite numbers, got {value!r}")
    return array


def _number(value: object, what: str, where: str, *, positive: bool) -> float:
    """A finite number > 0 (``positive``) or >= 0, else ModelCheckError naming the valid range."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise _fail(where, f"{what} must be a number, got {value!r}") from None
    if not np.isfinite(number) or number < 0 or (positive and number == 0):
        raise _fail(where, f"{what} must be {'> 0' if positive else '>= 0'}, got {value!r}")
    return number


def _unit(direction: np.ndarray, where: str) -> np.ndarray:
    norm = float(np.linalg.norm(direction))
    if norm < 1e-9:
        raise _fail(where, f"the thrust direction {direction.tolist()} is zero")
    return direction / norm


def _check_frame(name: str, valid: Sequence[str] | None, where: str, kind: str = "frame") -> None:
    """ModelCheckError for a frame (or joint) the model does not have, with the close names (difflib)."""
    if valid is None or name in valid:
        return
    close = difflib.get_close_matches(name, list(valid), n=5, cutoff=0.4)
    hint = f"close names: {', '.join(close)}" if close else f"valid {kind}s: {', '.join(list(valid)[:20])}"
    raise ModelCheckError(f"{where}: unknown {kind} {name!r}; {hint}; {VALID_FORM}")


def thruster_from_values(name: str, values: Mapping[str, object], defaults: Mapping[str, object],
                         frames: Sequence[str] | None, where: str) -> Thruster:
    """A Thruster from one YAML entry (or the values of a plugin), with the file defaults.

    Raises:
        ModelCheckError: an unknown key or frame, a zero direction, a bad limit or time constant.
    """
    unknown = sorted(str(key) for key in values if key not in THRUSTER_KEYS)
    if unknown:
        raise _fail(where, f"unknown key(s) {', '.join(unknown)} (valid: {', '.join(THRUSTER_KEYS)})")
    merged = {**defaults, **values}
    if ("frame" in values) == ("parent" in values):
        raise _fail(where, "give exactly one of frame and parent")
    if "frame" in values and any(key in values for key in ("xyz", "rpy", "direction")):
        raise _fail(where, "a frame thruster takes its pose from the frame; xyz, rpy and direction go with parent")
    if "rpy" in values and "direction" in values:
        raise _fail(where, "give rpy or direction, not both")
    parent = str(values.get("frame", values.get("parent")))
    _check_frame(parent, frames, where)
    position = _vector(values.get("xyz", [0.0, 0.0, 0.0]), "xyz", where)
    if "direction" in values:
        direction = _unit(_vector(values["direction"], "direction", where), where)
    else:
        direction = pin.rpy.rpyToMatrix(*_vector(values.get("rpy", [0.0, 0.0, 0.0]), "rpy", where))[:, 0]
    for key in ("max_forward", "max_reverse", "time_constant"):
        if key not in merged:
            raise _fail(where, f"{key} is missing")
    return Thruster(name=str(name), parent=parent, position=position, direction=direction,
                    max_forward=_number(merged["max_forward"], "max_forward", where, positive=True),
                    max_reverse=_number(merged["max_reverse"], "max_reverse", where, positive=False),
                    time_constant=_number(merged["time_constant"], "time_constant", where, positive=True))


# ------------------------------------------------------------------ YAML
def load_thrusters_yaml(path: str | os.PathLike, frames: Sequence[str] | None = None) -> Thrusters:
    """Thrusters from a YAML file (the form in the module docstring).

    Args:
        path: the file; frames: the model's frame names, checked (None: not checked here).

    Raises:
        ModelFileNotFound: the file cannot be read.
        ModelParseError: not YAML, or no ``thrusters`` mapping.
        ModelCheckError: invalid thruster data (the message names the file and the valid form).
    """
    path = Path(path)
    document = read_yaml(path, "thrusters")
    if not isinstance(document, Mapping) or not isinstance(document.get("thrusters"), Mapping) \
            or not document["thrusters"]:
        raise ModelParseError(f"{path}: expected a mapping with a non-empty 'thrusters' mapping (keys: "
                              f"{', '.join(TOP_KEYS)}); {VALID_FORM}")
    unknown = sorted(str(key) for key in document if key not in TOP_KEYS)
    if unknown:
        raise _fail(str(path), f"unknown key(s) {', '.join(unknown)} (valid: {', '.join(TOP_KEYS)})")
    defaults = {key: document[key] for key in TOP_KEYS[1:] if key in document}
    items = []
    for name, values in document["thrusters"].items():
        where = f"{path}: thruster {name!r}"
        if not isinstance(values, Mapping):
            raise _fail(where, f"expected a mapping, got {values!r}")
        items.append(thruster_from_values(str(name), values, defaults, frames, where))
    return Thrusters(tuple(items), source=str(path))


# ------------------------------------------------------------------ uuv_simulator plugin form
def _joint_axis(root: ET.Element, joint_name: str, link: str, where: str) -> np.ndarray:
    """The axis (child-link frame) of a URDF joint whose child is ``link``; x when it has no <axis>."""
    for joint in root.findall("joint"):
        if joint.get("name") == joint_name:
            child = joint.find("child")
            if child is None or child.get("link") != link:
                raise _fail(where, f"jointName {joint_name!r} does not carry linkName {link!r}")
            axis = joint.find("axis")
            return _vector(axis.get("xyz", "1 0 0"), "joint axis", where) if axis is not None else np.eye(3)[0]
    _check_frame(joint_name, [j.get("name", "") for j in root.findall("joint")], where, "joint")
    raise AssertionError("unreachable: _check_frame raised")  # pragma: no cover


def parse_thrusters_urdf(urdf: str, origin: str = "<string>", frames: Sequence[str] | None = None) -> Thrusters | None:
    """The thrusters of a URDF's uuv_simulator thruster plugins, or None when it has none.

    Raises:
        ModelParseError: not well-formed XML.
        ModelCheckError: a plugin without linkName or thrust limits, a zero axis, unknown link, a dynamics
            other than FirstOrder (the message says what is valid).
    """
    try:
        root = ET.fromstring(urdf)
    except ET.ParseError as exc:
        raise ModelParseError(f"{origin}: malformed XML ({exc})") from None
    plugins = [p for gazebo in root.findall("gazebo") for p in gazebo.findall("plugin") if is_thruster_plugin(p)]
    if not plugins:
        return None
    items = []
    for index, plugin in enumerate(plugins):
        name = plugin.get("name") or f"thruster_{index}"
        where = f"{origin}: thruster plugin {name!r}"
        link = (plugin.findtext("linkName") or "").strip()
        if not link:
            raise _fail(where, "<linkName> is missing")
        kind = (plugin.findtext("dynamics/type") or "").strip()
        if kind != "FirstOrder":
            raise _fail(where, f"dynamics type {kind or 'none'!r} is not supported; give <dynamics><type>FirstOrder"
                               f"</type><timeConstant>TAU</timeConstant></dynamics>")
        low, high = plugin.findtext("thrustMin"), plugin.findtext("thrustMax")
        if low is None or high is None:
            raise _fail(where, "<thrustMin> and <thrustMax> [N] are needed (uuv_simulator's default is unbounded)")
        lowest = _number(-float(low) if _is_number(low) else low, "-thrustMin", where, positive=False)
        joint = (plugin.findtext("jointName") or "").strip()
        values = {"parent": link, "max_forward": high, "max_reverse": lowest,
                  "time_constant": plugin.findtext("dynamics/timeConstant")}
        if joint:
            values["direction"] = _joint_axis(root, joint, link, where).tolist()
        items.append(thruster_from_values(name, values, {}, frames, where))
    return Thrusters(tuple(items), source=origin)


def _is_number(text: str) -> bool:
    try:
        float(text)
    except (TypeError, ValueError):
        return False
    return True


# ------------------------------------------------------------------ for a robot
def thrusters_of(robot: Robot, path: str | os.PathLike | None = None, *, required: bool = True) -> Thrusters:
    """The thrusters of a loaded Robot: ``path`` when given, else the URDF's plugins, else ``thrusters.yaml``
    beside the model file (both a plugin and that file: refused as ambiguous).

    Raises:
        UVMSError: no thrusters (and ``required``), or both plugins and a YAML file.
        ModelCheckError, ModelParseError: invalid thruster data.
    """
    from ..robot.robot import check_robot  # at call time: robot.py imports this package

    check_robot(robot, "thrusters_of")
    frames = robot.frame_names
    if path is not None:
        thrusters = load_thrusters_yaml(path, frames)
    else:
        from_urdf = parse_thrusters_urdf(robot.urdf, robot.source, frames) if robot.urdf else None
        folder = Path(robot.source).parent if robot.source and not robot.source.startswith("<") else None
        beside = folder / YAML_NAME if folder is not None and (folder / YAML_NAME).is_file() else None
        if from_urdf is not None and beside is not None:
            raise UVMSError(f"{robot.source}: thrusters are both in the model's uuv_simulator plugins and in {beside};"
                            f" pass path= to choose the YAML, or remove one")
        thrusters = from_urdf if from_urdf is not None else (
            load_thrusters_yaml(beside, frames) if beside is not None else None)
    if thrusters is None:
        if required:
            raise UVMSError(f"{robot.source}: the model has no thrusters; add uuv_simulator thruster plugins to the "
                            f"URDF or a {YAML_NAME} beside it (see uvms.dynamics.thrusters)")
        return Thrusters((), source=f"{robot.source} (no thrusters)")
    return thrusters


# ------------------------------------------------------------------ geometry on the model
def placements_in_base(robot: Robot, thrusters: Thrusters) -> tuple[np.ndarray, np.ndarray]:
    """Points (n, 3) [m] and unit directions (n, 3) of the thrusters in the vehicle's base frame.

    Read from the Pinocchio frames: base_M_thruster = (joint_M_base)^-1 joint_M_parent, both frames fixed
    to the vehicle's joint, so the placement does not depend on the configuration.

    Raises:
        ModelCheckError: a thruster on an arm link (not rigidly fixed to the vehicle), or a fixed base.
    """
    if robot.base_type == "fixed":
        raise ModelCheckError(f"{robot.name} has a fixed base: thrusters need a floating or planar vehicle")
    model = robot.model
    base = model.frames[model.getFrameId(robot.root_link)]
    points, directions = [], []
    for thruster in thrusters.items:
        frame = model.frames[model.getFrameId(thruster.parent)]
        if frame.parentJoint != base.parentJoint:
            raise ModelCheckError(
                f"{thrusters.source}: thruster {thruster.name!r} is on frame {thruster.parent!r}, which moves with "
                f"joint {model.names[frame.parentJoint]!r}; a thruster must be fixed to the vehicle body "
                f"({robot.root_link!r} or a frame fixed to it)")
        base_m_parent = base.placement.actInv(frame.placement)  # (joint_M_base)^-1 joint_M_parent
        points.append(base_m_parent.act(thruster.position))
        directions.append(base_m_parent.rotation @ thruster.direction)
    return np.array(points).reshape(-1, 3), np.array(directions).reshape(-1, 3)


def allocation_matrix(robot: Robot, thrusters: Thrusters) -> np.ndarray:
    """The thruster allocation matrix B (6, n): body wrench [N, N m] at the base frame origin, FLU, per N.

    Column i is [d_i; p_i x d_i] with p_i, d_i the thruster's point and direction in the base frame
    (:func:`placements_in_base`), so that tau = B f.
    """
    points, directions = placements_in_base(robot, thrusters)
    return np.vstack([directions.T, np.cross(points, directions).T])  # (6, n)
