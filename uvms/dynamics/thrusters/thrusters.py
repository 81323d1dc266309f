"""Thrusters of a vehicle as model data: a frame, thrust limits and a first-order time constant each.

A thruster is a frame of the model: its x axis is the direction of positive thrust and its origin
the point where the thrust acts. It pushes with f in [-max_reverse, +max_forward] [N] and follows
its command through a first-order lag f' = (f_cmd - f) / time_constant.

Where they come from
====================
The thruster plugins in the URDF, one per thruster, of uuv_simulator (what is read from them:
:mod:`uvms.dynamics.thrusters.sources`), Gazebo Sim (``gz::sim::systems::Thruster``:
:mod:`uvms.dynamics.plugins.gz_sim`) or HippoCampus (``hippo_gz_plugins::thruster``:
:mod:`uvms.dynamics.plugins.hippo`), e.g. uuv_simulator's::

    <plugin name="thruster_1" filename="libuuv_thruster_ros_plugin.so">
      <linkName>thruster_1</linkName>       <!-- a link of the model: thrust along its x axis at the joint's zero -->
      <jointName>thruster_1_joint</jointName> <!-- optional: thrust along this joint's axis -->
      <thrustMin>-40.2</thrustMin> <thrustMax>51.5</thrustMax>       <!-- [N], optional -->
      <dynamics><type>FirstOrder</type><timeConstant>0.1</timeConstant></dynamics>
      <conversion><type>Basic</type><rotorConstant>0.00031</rotorConstant></conversion>
    </plugin>

and a ``thrusters.yaml`` beside the model (or given as ``path``)::

    time_constant: 0.1            # optional file default [s]
    max_forward: 51.5             # optional file default [N], > 0
    max_reverse: 40.2             # optional file default [N], >= 0 (a positive number)
    thrusters:
      thruster_1:                 # a name of your choice
        parent: base_link         # a frame of the model the thruster is fixed to
        xyz: [0.14, -0.092, 0.0]  # [m] origin in the parent frame (default 0)
        rpy: [0.0, 0.0, -2.356]   # [rad] thrust = x axis of Rz Ry Rx (default 0) ...
        direction: [-1, -1, 0]    # ... or the thrust direction itself, in the parent frame
        max_forward: 51.5         # per-thruster values win over the file defaults
      thruster_2:
        frame: thruster_2_link    # or a frame of the model (e.g. a fixed link added in the xacro): its x axis

A model with plugins takes the thrusters from them, and the YAML completes them per thruster: an entry named as a
plugin gives its max_forward, max_reverse or time_constant (and wins over the plugin's), the file defaults give
what neither gives, and what is still missing takes :data:`DEFAULT_VALUES` with a :class:`ThrusterDefaultWarning`
(:func:`complete_plugin_thrusters`). A model without plugins takes the YAML alone, every value given.

A thruster must be fixed to the vehicle body (it may not ride on an arm link): its placement in the vehicle's
base frame is then constant, and so is the allocation matrix (:func:`allocation_matrix`). uuv_simulator mounts
each thruster link on a continuous propeller joint about the thrust axis; that joint must be frozen (fixed) in
the loaded model, and the thrust then acts along the link's (or joint's) axis at the joint's zero.
"""

from __future__ import annotations

import difflib
import os
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from ...errors import ModelCheckError, ModelParseError, ThrusterDefaultWarning, UVMSError
from ..plugins.readers import read_thruster_plugins
from .sources import LIMIT_KEYS, THRUSTER_KEYS, PluginThruster, fail, read_thrusters_document

if TYPE_CHECKING:
    from ...robot.robot import Robot

YAML_NAME = "thrusters.yaml"  #: Name of the YAML file looked for beside a model.
#: What a plugin thruster gets when neither its plugin nor the YAML gives a value: uuv_simulator's RexROV, whose
#: plugins give neither limits nor (with FirstOrder) anything but the time constant.
DEFAULT_VALUES = {"max_forward": 2000.0, "max_reverse": 2000.0, "time_constant": 0.05}
DEFAULTS_WHY = ("These are uuv_simulator's RexROV values: max_thrust 2000 N of its thruster manager (uuv_simulator "
                "docs, 'Configuring the thruster manager') and the 0.05 s time constant of rexrov_actuators.xacro. "
                "A uuv_simulator plugin gives limits by thrustMin/thrustMax, a clamp or a LinearInterp table, and a "
                "time constant with FirstOrder dynamics only; a Gazebo Sim Thruster limits by max_thrust_cmd/"
                "min_thrust_cmd and has no time constant; a HippoCampus thruster limits by maximum_rpm and its "
                "thrust coefficients, its time constant is timeconstant_up = timeconstant_down > 0; give your "
                f"thrusters' values there or in {YAML_NAME} (max_forward, max_reverse, time_constant, per thruster "
                "or as file defaults)")


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
def _vector(value: object, what: str, where: str) -> np.ndarray:
    """Three finite numbers from a list or from text ("1 0 0")."""
    try:
        array = np.array([float(x) for x in value.split()] if isinstance(value, str) else value, dtype=float).ravel()
    except (TypeError, ValueError):
        raise fail(where, f"{what} must be 3 numbers, got {value!r}") from None
    if array.shape != (3,) or not np.all(np.isfinite(array)):
        raise fail(where, f"{what} must be 3 finite numbers, got {value!r}")
    return array


def _number(value: object, what: str, where: str, *, positive: bool) -> float:
    """A finite number > 0 (``positive``) or >= 0, else ModelCheckError naming the valid range."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise fail(where, f"{what} must be a number, got {value!r}") from None
    if not np.isfinite(number) or number < 0 or (positive and number == 0):
        raise fail(where, f"{what} must be {'> 0' if positive else '>= 0'}, got {value!r}")
    return number


def _unit(direction: np.ndarray, where: str) -> np.ndarray:
    norm = float(np.linalg.norm(direction))
    if norm < 1e-9:
        raise fail(where, f"the thrust direction {direction.tolist()} is zero")
    return direction / norm


def _check_frame(name: str, valid: Sequence[str] | None, where: str) -> None:
    """ModelCheckError for a frame the model does not have, with the close names (difflib)."""
    if valid is None or name in valid:
        return
    close = difflib.get_close_matches(name, list(valid), n=5, cutoff=0.4)
    hint = f"close names: {', '.join(close)}" if close else f"valid frames: {', '.join(list(valid)[:20])}"
    raise fail(where, f"unknown frame {name!r}; {hint}")


def thruster_from_values(name: str, values: Mapping[str, object], defaults: Mapping[str, object],
                         frames: Sequence[str] | None, where: str) -> Thruster:
    """A Thruster from one YAML entry (or the values of a plugin), with the file defaults.

    Raises:
        ModelCheckError: an unknown key or frame, a zero direction, a bad limit or time constant.
    """
    unknown = sorted(str(key) for key in values if key not in THRUSTER_KEYS)
    if unknown:
        raise fail(where, f"unknown key(s) {', '.join(unknown)} (valid: {', '.join(THRUSTER_KEYS)})")
    merged = {**defaults, **values}
    if ("frame" in values) == ("parent" in values):
        raise fail(where, "give exactly one of frame and parent")
    if "frame" in values and any(key in values for key in ("xyz", "rpy", "direction")):
        raise fail(where, "a frame thruster takes its pose from the frame; xyz, rpy and direction go with parent")
    if "rpy" in values and "direction" in values:
        raise fail(where, "give rpy or direction, not both")
    parent = str(values.get("frame", values.get("parent")))
    _check_frame(parent, frames, where)
    position = _vector(values.get("xyz", [0.0, 0.0, 0.0]), "xyz", where)
    if "direction" in values:
        direction = _unit(_vector(values["direction"], "direction", where), where)
    else:
        direction = pin.rpy.rpyToMatrix(*_vector(values.get("rpy", [0.0, 0.0, 0.0]), "rpy", where))[:, 0]
    for key in LIMIT_KEYS:
        if key not in merged:
            raise fail(where, f"{key} is missing")
    return Thruster(name=str(name), parent=parent, position=position, direction=direction,
                    max_forward=_number(merged["max_forward"], "max_forward", where, positive=True),
                    max_reverse=_number(merged["max_reverse"], "max_reverse", where, positive=False),
                    time_constant=_number(merged["time_constant"], "time_constant", where, positive=True))


# ------------------------------------------------------------------ YAML
def load_thrusters_yaml(path: str | os.PathLike, frames: Sequence[str] | None = None) -> Thrusters:
    """Thrusters from a YAML file (the form in the module docstring), for a model without thruster plugins.

    Args:
        path: the file; frames: the model's frame names, checked (None: not checked here).

    Raises:
        ModelFileNotFound: the file cannot be read.
        ModelParseError: not YAML, or no ``thrusters`` mapping.
        ModelCheckError: invalid thruster data (the message names the file and the valid form).
    """
    defaults, entries = read_thrusters_document(path, entries_required=True)
    items = [thruster_from_values(name, values, defaults, frames, f"{path}: thruster {name!r}")
             for name, values in entries.items()]
    return Thrusters(tuple(items), source=str(path))


# ------------------------------------------------------------------ simulator plugins, completed
def complete_plugin_thrusters(plugins: Sequence[PluginThruster], origin: str, frames: Sequence[str] | None = None,
                              completion: str | os.PathLike | None = None) -> Thrusters:
    """The Thrusters of simulator plugins, each value from the first source that gives it.

    For each of max_forward, max_reverse and time_constant of a thruster: its entry in the completion YAML
    (same name as the plugin; the user's own word, so it wins over the plugin), else the plugin
    (:mod:`uvms.dynamics.thrusters.sources`), else the file default of the YAML, else uvms's default
    (:data:`DEFAULT_VALUES`) with one :class:`ThrusterDefaultWarning` naming the thrusters that got it.

    Args:
        plugins: the plugins (:func:`~uvms.dynamics.plugins.readers.read_thruster_plugins`); origin: the model,
            for messages; frames: the model's frame names (checked); completion: the YAML file that completes
            them (None: none).

    Raises:
        ModelCheckError: a YAML entry that names no plugin thruster or gives a pose, invalid values.
    """
    defaults, entries = read_thrusters_document(completion, entries_required=False) if completion else ({}, {})
    names = [plugin.name for plugin in plugins]
    for key, value in defaults.items():  # values checked where the message can name the YAML
        _number(value, key, str(completion), positive=key != "max_reverse")
    for name, entry in entries.items():
        where = f"{completion}: thruster {name!r}"
        if name not in names:
            raise ModelCheckError(f"{where}: no thruster plugin of the model has this name; an entry completes the "
                                  f"plugin of the same name: {', '.join(names)}")
        posed = sorted(str(key) for key in entry if key not in LIMIT_KEYS)
        if posed:
            raise fail(where, f"it completes the thruster plugin {name!r}, whose link gives the pose; give only "
                               f"{', '.join(LIMIT_KEYS)} (not {', '.join(posed)})")
        for key, value in entry.items():
            _number(value, key, where, positive=key != "max_reverse")
    items, defaulted = [], {}
    for plugin in plugins:
        where = f"{origin}: thruster plugin {plugin.name!r}"
        values: dict[str, object] = {"parent": plugin.link}
        if plugin.direction is not None:
            values["direction"] = plugin.direction.tolist()
        for key in LIMIT_KEYS:
            source = next(s for s in (entries.get(plugin.name, {}), plugin.given, defaults, DEFAULT_VALUES) if key in s)
            values[key] = source[key]
            if source is DEFAULT_VALUES:
                defaulted.setdefault(key, []).append(plugin.name)
        items.append(thruster_from_values(plugin.name, values, {}, frames, where))
    if defaulted:
        warnings.warn(f"{origin}: uvms's default thruster values for what neither the thruster plugins nor "
                      f"{completion or 'a ' + YAML_NAME + ' beside the model'} give: " + "; ".join(
                          f"{key} = {DEFAULT_VALUES[key]:g} {'s' if key == 'time_constant' else 'N'} for "
                          f"{', '.join(who)}" for key, who in defaulted.items()) + f". {DEFAULTS_WHY}",
                      ThrusterDefaultWarning, stacklevel=3)
    return Thrusters(tuple(items), source=origin if completion is None else f"{origin} + {completion}")


def parse_thrusters_urdf(urdf: str, origin: str = "<string>", frames: Sequence[str] | None = None,
                         completion: str | os.PathLike | None = None) -> Thrusters | None:
    """The thrusters of a URDF's thruster plugins (completed, :func:`complete_plugin_thrusters`),
    or None when it has none.

    Raises:
        ModelParseError: not well-formed XML.
        ModelCheckError: a plugin without linkName, a zero axis, an unknown link, invalid values.
    """
    try:
        root = ET.fromstring(urdf)
    except ET.ParseError as exc:
        raise ModelParseError(f"{origin}: malformed XML ({exc})") from None
    plugins = read_thruster_plugins(root, origin)
    return complete_plugin_thrusters(plugins, origin, frames, completion) if plugins else None


# ------------------------------------------------------------------ for a robot
def thrusters_of(robot: Robot, path: str | os.PathLike | None = None, *, required: bool = True) -> Thrusters:
    """The thrusters of a loaded Robot: the URDF's thruster plugins completed by the YAML, or the YAML alone.

    The YAML is ``path`` when given, else ``thrusters.yaml`` beside the model file when there is one. With
    plugins it completes them (:func:`complete_plugin_thrusters`); without, it describes the thrusters
    (:func:`load_thrusters_yaml`).

    Raises:
        UVMSError: no thrusters (and ``required``).
        ModelCheckError, ModelParseError: invalid thruster data.
    """
    from ...robot.robot import check_robot  # at call time: robot.py imports this package

    check_robot(robot, "thrusters_of")
    frames = robot.frame_names
    folder = Path(robot.source).parent if robot.source and not robot.source.startswith("<") else None
    beside = folder / YAML_NAME if folder is not None and (folder / YAML_NAME).is_file() else None
    yaml_path = Path(path) if path is not None else beside
    root = robot.urdf_root
    plugins = read_thruster_plugins(root, robot.source) if root is not None else []
    if plugins:
        return complete_plugin_thrusters(plugins, robot.source, frames, yaml_path)
    if yaml_path is not None:
        return load_thrusters_yaml(yaml_path, frames)
    if required:
        raise UVMSError(f"{robot.source}: the model has no thrusters; add thruster plugins (uuv_simulator, Gazebo "
                        f"Sim or HippoCampus) to the URDF or a {YAML_NAME} "
                        "beside it (see uvms.dynamics.thrusters.thrusters)")
    return Thrusters((), source=f"{robot.source} (no thrusters)")


# ------------------------------------------------------------------ geometry on the model
def placements_in_base(robot: Robot, thrusters: Thrusters) -> tuple[np.ndarray, np.ndarray]:
    """Points (n, 3) [m] and unit directions (n, 3) of the thrusters in the vehicle's base frame.

    Read from the Pinocchio frames: base_M_thruster = (joint_M_base)^-1 joint_M_parent, both frames fixed
    to the vehicle's joint, so the placement does not depend on the configuration. A propeller joint frozen
    by the loader leaves its link fixed to the vehicle at the joint's zero.

    Raises:
        ModelCheckError: a thruster on a link that moves with a joint (an arm link, or a propeller joint that is
            not frozen), or a fixed base.
    """
    if robot.base_type == "fixed":
        raise ModelCheckError(f"{robot.name} has a fixed base: thrusters need a floating or planar vehicle")
    model = robot.model
    base = model.frames[model.getFrameId(robot.root_link)]
    points, directions = [], []
    for thruster in thrusters.items:
        frame = model.frames[model.getFrameId(thruster.parent)]
        if frame.parentJoint != base.parentJoint:
            raise ModelCheckError(_moving_thruster_message(robot, thrusters.source, thruster, frame.parentJoint))
        base_m_parent = base.placement.actInv(frame.placement)  # (joint_M_base)^-1 joint_M_parent
        points.append(base_m_parent.act(thruster.position))
        directions.append(base_m_parent.rotation @ thruster.direction)
    return np.array(points).reshape(-1, 3), np.array(directions).reshape(-1, 3)


def _moving_thruster_message(robot: Robot, source: str, thruster: Thruster, joint: int) -> str:
    """Why a thruster on a moving link is refused; a joint right on the vehicle is taken for a propeller joint."""
    model = robot.model
    text = (f"{source}: thruster {thruster.name!r} is on frame {thruster.parent!r}, which moves with joint "
            f"{model.names[joint]!r}; a thruster must be fixed to the vehicle body ({robot.root_link!r} or a frame "
            f"fixed to it)")
    if model.parents[joint] == model.frames[model.getFrameId(robot.root_link)].parentJoint:
        text += (f"; if {model.names[joint]!r} is the thruster's propeller joint (uuv_simulator mounts each "
                 f"thruster link on a continuous joint about its thrust axis), it must be frozen in the loaded "
                 f"model (a fixed joint: write type=\"fixed\" or let the loader freeze propeller joints); the "
                 f"thrust then acts along the link's axis at the joint's zero")
    return text


def allocation_matrix(robot: Robot, thrusters: Thrusters) -> np.ndarray:
    """The thruster allocation matrix B (6, n): body wrench [N, N m] at the base frame origin, FLU, per N.

    Column i is [d_i; p_i x d_i] with p_i, d_i the thruster's point and direction in the base frame
    (:func:`placements_in_base`), so that tau = B f.
    """
    points, directions = placements_in_base(robot, thrusters)
    return np.vstack([directions.T, np.cross(points, directions).T])  # (6, n)


def thruster_rows(robot: Robot, thrusters: Thrusters) -> list[dict[str, object]]:
    """One plain row per thruster for a table (``uvms info``): where it is and what it can do.

    Returns:
        [{"name": str, "frame": str, "position": [x, y, z] [m] and "direction": [dx, dy, dz] (unit), both in the
        vehicle's base frame (FLU), "max_forward": float [N], "max_reverse": float [N] (f >= -max_reverse),
        "time_constant": float [s]}], in the order of the thrusts.

    Raises:
        ModelCheckError: as :func:`placements_in_base`.
    """
    points, directions = placements_in_base(robot, thrusters)
    return [{"name": thruster.name, "frame": thruster.parent, "position": point.tolist(),
             "direction": direction.tolist(), "max_forward": thruster.max_forward,
             "max_reverse": thruster.max_reverse, "time_constant": thruster.time_constant}
            for thruster, point, direction in zip(thrusters.items, points, directions)]
