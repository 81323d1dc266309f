"""What a model's files say about its thrusters, read and checked for their form: uuv_simulator's thruster plugins
(``libuuv_thruster_ros_plugin.so``) in the URDF and the thrusters YAML document (:func:`read_thrusters_document`).
:mod:`uvms.dynamics.thrusters.thrusters` builds the Thrusters from them.

The plugin: where each thruster pushes and what it says about the thrust limits and the time constant.

What the plugin computes each step (uuv_simulator, ``uuv_gazebo_plugins/src/ThrusterPlugin.cc``, ``Dynamics.cc``,
``ThrusterConversionFcn.cc``): the input command clamped to [``clampMin``, ``clampMax``], times ``gain``, through
the rotor ``<dynamics>`` (``ZeroOrder``: none, ``FirstOrder``: a lag of ``timeConstant``, ``Yoerger``, ``Bessa``),
times ``propeller_efficiency``, converted to a thrust by ``<conversion>`` (``Basic``: rotorConstant x|x|,
``Bessa``: the same with a dead zone, ``LinearInterp``: a table, constant beyond its ends), times
``thrust_efficiency``, clipped to [``thrustMin``, ``thrustMax``]. The thrust pushes along the thruster link's x
axis, or along the axis of ``<jointName>`` (later versions of the plugin).

What uvms reads from it (:func:`read_uuv_thruster`; the readers of every simulator:
:mod:`uvms.dynamics.plugins.readers`):

* the limits: the range of thrust that chain can hold in steady state (:func:`plugin_thrust_range`). A side
  left unbounded (uuv_simulator's defaults: no clamp and no thrustMin/thrustMax with a Basic conversion, as the
  RexROV's ``thruster_snippets.xacro`` writes them) is a limit the plugin does not give.
* the time constant: ``timeConstant`` of a ``FirstOrder`` dynamics. ``ZeroOrder`` means no lag at all, and the
  nonlinear rotor models are no first-order lag on the thrust; uvms models every thruster as a first-order lag
  (:mod:`uvms.dynamics.plant.actuated`), so for them the plugin gives no time constant.

What a plugin does not give is completed by ``thrusters.yaml`` or a documented default
(:func:`uvms.dynamics.thrusters.thrusters.complete_plugin_thrusters`).
"""

from __future__ import annotations

import difflib
import math
import os
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...errors import ModelCheckError, ModelParseError
from ...model.resources import read_yaml

#: How one thruster is written, quoted by every error about thruster data.
VALID_FORM = ("a thruster is {frame: FRAME} or {parent: FRAME, xyz: [x, y, z] m, rpy: [r, p, y] rad or direction: "
              "[dx, dy, dz] (not zero)}, with max_forward > 0 N, max_reverse >= 0 N (a positive number) and "
              "time_constant > 0 s (each given per thruster or as a file default)")
LIMIT_KEYS = ("max_forward", "max_reverse", "time_constant")
THRUSTER_KEYS = ("frame", "parent", "xyz", "rpy", "direction") + LIMIT_KEYS
TOP_KEYS = ("thrusters",) + LIMIT_KEYS
#: The dynamics whose steady state is the (clamped) command itself.
LINEAR_DYNAMICS = ("ZeroOrder", "FirstOrder")


@dataclass(frozen=True)
class PluginThruster:
    """One thruster plugin, as far as it describes the thruster.

    Attributes:
        name: the plugin's ``name`` attribute.
        link: ``linkName``, the link the thrust acts on (a frame of the model).
        direction: (3,) the axis of ``jointName`` in the link frame, or None (no jointName: the link's x axis).
        given: the values the plugin gives, among ``max_forward``, ``max_reverse`` [N] and ``time_constant`` [s].
    """

    name: str
    link: str
    direction: np.ndarray | None
    given: dict[str, float]


def fail(where: str, problem: str) -> ModelCheckError:
    """The ModelCheckError about thruster data: where, what is wrong, and the valid form."""
    return ModelCheckError(f"{where}: {problem}; {VALID_FORM}")


def read_thrusters_document(path: str | os.PathLike, *, entries_required: bool) -> tuple[dict, dict]:
    """The file defaults and the ``thrusters`` entries of a thrusters YAML file, checked for their form.

    Args:
        path: the file; entries_required: a ``thrusters`` mapping must be there and not empty (a file that only
            completes plugin thrusters may give file defaults alone).

    Returns:
        ({key: value} of the file defaults, {thruster name: mapping of its values}).

    Raises:
        ModelFileNotFound: the file cannot be read.
        ModelParseError: not YAML, or not a mapping (with a non-empty ``thrusters`` mapping when required).
        ModelCheckError: unknown top-level keys, an entry that is not a mapping.
    """
    document = read_yaml(Path(path), "thrusters")
    document = {} if document is None and not entries_required else document
    entries = document.get("thrusters", None if entries_required else {}) if isinstance(document, Mapping) else None
    if not isinstance(entries, Mapping) or (entries_required and not entries):
        raise ModelParseError(f"{path}: expected a mapping with a non-empty 'thrusters' mapping (keys: "
                              f"{', '.join(TOP_KEYS)}); {VALID_FORM}")
    unknown = sorted(str(key) for key in document if key not in TOP_KEYS)
    if unknown:
        raise fail(str(path), f"unknown key(s) {', '.join(unknown)} (valid: {', '.join(TOP_KEYS)})")
    for name, values in entries.items():
        if not isinstance(values, Mapping):
            raise fail(f"{path}: thruster {name!r}", f"expected a mapping, got {values!r}")
    return {key: document[key] for key in LIMIT_KEYS if key in document}, {str(k): v for k, v in entries.items()}


def read_uuv_thruster(plugin: ET.Element, root: ET.Element, name: str, where: str) -> PluginThruster:
    """What one uuv_simulator thruster plugin says (the module docstring); registered for uuv_simulator in
    :data:`uvms.dynamics.plugins.readers.THRUSTER_READERS`.

    Args:
        plugin: the ``<plugin>``; root: the URDF ``<robot>``; name: the thruster's name; where: for messages.

    Raises:
        ModelCheckError: no ``linkName``, a jointName that is no joint of the model or does not carry the link, a
            non-numeric value, thrustMin >= thrustMax, a thrust range without positive thrust or with a positive
            lowest thrust.
    """
    link = (plugin.findtext("linkName") or "").strip()
    if not link:
        raise ModelCheckError(f"{where}: <linkName> is missing; it names the link the thrust acts on")
    low, high = plugin_thrust_range(plugin, where)
    given = thrust_limits(low, high, where, "check thrustMax, the clamp and the conversion")
    tau = plugin_time_constant(plugin, where)
    if tau is not None:
        given["time_constant"] = tau
    joint = (plugin.findtext("jointName") or "").strip()
    return PluginThruster(name, link, joint_axis(root, joint, link, where) if joint else None, given)


def thrust_limits(low: float, high: float, where: str, check: str) -> dict[str, float]:
    """{max_forward, max_reverse} [N] of a plugin's thrust range [low, high] (a side that is infinite: not given).

    Raises:
        ModelCheckError: a largest thrust <= 0 or a lowest thrust > 0 (``check``: what to look at).
    """
    given = {}
    if math.isfinite(high):
        if high <= 0:
            raise ModelCheckError(f"{where}: its largest thrust is {high:g} N; a thruster must push forward "
                                  f"(> 0 N): {check}")
        given["max_forward"] = high
    if math.isfinite(low):
        if low > 0:
            raise ModelCheckError(f"{where}: its lowest thrust is {low:g} N; it must be <= 0 N (a thruster must "
                                  f"allow zero thrust): {check}")
        given["max_reverse"] = -low
    return given


def joint_axis(root: ET.Element, joint_name: str, link: str, where: str) -> np.ndarray:
    """The unit axis (3,) of a URDF joint whose child is ``link``, in the link frame; x when it has no <axis>.

    The axis of a propeller joint at its zero: spinning about it leaves it (and the thrust) where it is.

    Raises:
        ModelCheckError: no such joint (with the close names), a joint that does not carry ``link``, a zero axis.
    """
    joints = {joint.get("name", ""): joint for joint in root.findall("joint")}
    if joint_name not in joints:
        close = difflib.get_close_matches(joint_name, list(joints), n=5, cutoff=0.4)
        hint = f"close names: {', '.join(close)}" if close else f"valid joints: {', '.join(list(joints)[:20])}"
        raise fail(where, f"unknown joint {joint_name!r}; {hint}")
    child = joints[joint_name].find("child")
    if child is None or child.get("link") != link:
        raise fail(where, f"jointName {joint_name!r} does not carry linkName {link!r}")
    axis = joints[joint_name].find("axis")
    values = _floats("1 0 0" if axis is None else axis.get("xyz", "1 0 0"), "axis", where)
    if values.shape != (3,) or np.linalg.norm(values) < 1e-9:
        raise fail(where, f"the axis of joint {joint_name!r} must be 3 numbers, not all zero, got {values.tolist()}")
    return values / np.linalg.norm(values)


def plugin_time_constant(plugin: ET.Element, where: str) -> float | None:
    """``timeConstant`` [s] of a FirstOrder ``<dynamics>``, else None (ZeroOrder, Yoerger, Bessa, none given).

    Raises:
        ModelCheckError: a FirstOrder time constant that is not a number > 0.
    """
    if (plugin.findtext("dynamics/type") or "").strip() != "FirstOrder":
        return None
    text = plugin.findtext("dynamics/timeConstant")
    if text is None:
        return None
    tau = _float(text, "dynamics/timeConstant", where)
    if not tau > 0:
        raise ModelCheckError(f"{where}: the FirstOrder timeConstant must be > 0 s, got {text.strip()!r}")
    return tau


def plugin_thrust_range(plugin: ET.Element, where: str) -> tuple[float, float]:
    """The thrust range [low, high] [N] a plugin can hold in steady state; -inf / inf on a side it leaves open.

    The conversion over the rotor states reachable in steady state, times ``thrust_efficiency``, within
    [``thrustMin``, ``thrustMax``]. With a linear rotor dynamics (ZeroOrder, FirstOrder) the steady rotor state is
    the clamped command times ``gain`` and ``propeller_efficiency``; with a nonlinear one uvms does not solve for
    it and takes every state as reachable (a LinearInterp table still bounds the thrust then).

    Raises:
        ModelCheckError: a value that is not a number, thrustMin >= thrustMax.
    """
    states = _rotor_states(plugin, where)
    low, high = _conversion_range(plugin.find("conversion"), states, where)
    efficiency = _optional(plugin, "thrust_efficiency", 1.0, where)
    if 0.0 <= efficiency <= 1.0:  # the plugin ignores a factor outside [0, 1]
        low, high = _scaled(low, efficiency), _scaled(high, efficiency)
    thrust_min = _optional(plugin, "thrustMin", -math.inf, where)
    thrust_max = _optional(plugin, "thrustMax", math.inf, where)
    if thrust_min >= thrust_max:
        raise ModelCheckError(f"{where}: thrustMin ({thrust_min:g} N) must be below thrustMax ({thrust_max:g} N)")
    return max(low, thrust_min), min(high, thrust_max)


def _rotor_states(plugin: ET.Element, where: str) -> tuple[float, float]:
    """The interval of rotor states reachable in steady state (-inf, inf when not bounded or not known)."""
    if (plugin.findtext("dynamics/type") or "").strip() not in LINEAR_DYNAMICS:
        return -math.inf, math.inf
    clamp_min = _optional(plugin, "clampMin", -math.inf, where)
    clamp_max = _optional(plugin, "clampMax", math.inf, where)
    if clamp_min >= clamp_max:  # as the plugin: an empty clamp is no clamp
        clamp_min, clamp_max = -math.inf, math.inf
    scale = _optional(plugin, "gain", 1.0, where)
    efficiency = _optional(plugin, "propeller_efficiency", 1.0, where)
    if 0.0 <= efficiency <= 1.0:
        scale *= efficiency
    ends = sorted((_scaled(clamp_min, scale), _scaled(clamp_max, scale)))
    return ends[0], ends[1]


def _conversion_range(conversion: ET.Element | None, states: tuple[float, float], where: str) -> tuple[float, float]:
    """The thrust range [N] of the conversion function over the rotor states (unbounded when it has none)."""
    kind = "" if conversion is None else (conversion.findtext("type") or "").strip()
    if kind == "LinearInterp":
        inputs = _floats(conversion.findtext("inputValues"), "conversion/inputValues", where)
        outputs = _floats(conversion.findtext("outputValues"), "conversion/outputValues", where)
        if inputs.size == 0 or inputs.size != outputs.size:
            raise ModelCheckError(f"{where}: a LinearInterp conversion needs as many inputValues as outputValues "
                                  f"(at least one), got {inputs.size} and {outputs.size}")
        order = np.argsort(inputs)
        inputs, outputs = inputs[order], outputs[order]
        inside = outputs[(inputs > states[0]) & (inputs < states[1])]
        values = np.concatenate([np.interp(np.clip(states, inputs[0], inputs[-1]), inputs, outputs), inside])
        return float(values.min()), float(values.max())
    if kind == "Basic":
        constant = _float(conversion.findtext("rotorConstant"), "conversion/rotorConstant", where)
        values = [_basic(constant, state) for state in states]
    elif kind == "Bessa":
        values = [_bessa(conversion, state, where) for state in states]
    else:
        return -math.inf, math.inf
    return min(values), max(values)


def _basic(constant: float, state: float) -> float:
    """rotorConstant x |x|, extended to x = +-inf (both conversions are monotonic in x)."""
    if math.isinf(state):
        return 0.0 if constant == 0 else math.copysign(math.inf, constant * state)
    return constant * state * abs(state)


def _bessa(conversion: ET.Element, state: float, where: str) -> float:
    """The dead-zone conversion of ``ThrusterConversionFcn.cc`` at a rotor state (possibly infinite)."""
    left, right, delta_left, delta_right = (
        _float(conversion.findtext(tag), f"conversion/{tag}", where)
        for tag in ("rotorConstantL", "rotorConstantR", "deltaL", "deltaR"))
    basic = _basic(1.0, state)
    if basic <= delta_left:
        return _basic(left, -math.inf) if math.isinf(basic) else left * (basic - delta_left)
    if basic >= delta_right:
        return _basic(right, math.inf) if math.isinf(basic) else right * (basic - delta_right)
    return 0.0


def _scaled(value: float, factor: float) -> float:
    """value * factor with 0 * inf = 0 (a zero gain holds the rotor still)."""
    return 0.0 if factor == 0 else value * factor


def _optional(plugin: ET.Element, tag: str, default: float, where: str) -> float:
    text = plugin.findtext(tag)
    return default if text is None else _float(text, tag, where)


def _float(text: str | None, what: str, where: str) -> float:
    try:
        value = float((text or "").strip())
    except ValueError:
        raise ModelCheckError(f"{where}: <{what}> must be a number, got {text!r}") from None
    if math.isnan(value):
        raise ModelCheckError(f"{where}: <{what}> must be a number, got {text!r}")
    return value


def _floats(text: str | None, what: str, where: str) -> np.ndarray:
    try:
        values = np.array([float(token) for token in (text or "").split()], dtype=float)
    except ValueError:
        raise ModelCheckError(f"{where}: <{what}> must be numbers, got {text!r}") from None
    if not np.all(np.isfinite(values)):
        raise ModelCheckError(f"{where}: <{what}> must be finite numbers, got {text!r}")
    return values
