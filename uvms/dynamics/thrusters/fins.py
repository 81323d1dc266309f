"""Fins (control surfaces) of a vehicle as model data: the lift and drag of each at the vehicle's speed and its angle.

A fin is a plugin of the model file (:mod:`uvms.model.control_surfaces`): uuv_simulator's fin plugin or Gazebo Sim's
LiftDrag, on a link that a revolute joint turns. uvms freezes the joint in the kinematics (class ``fin``) and makes
its angle an actuator of the actuated plant (:class:`uvms.dynamics.plant.actuated.ActuatedPlant`): a first-order lag
delta' = (sat(delta_cmd) - delta) / time_constant within the joint's limits, and the plugin's lift and drag
(:mod:`uvms.dynamics.thrusters.lift_drag`) at the link turned by delta, fixed to the vehicle body.

What is read (uuv_simulator: ``uuv_gazebo_plugins/src/FinPlugin.cc``; Gazebo Sim:
``src/systems/lift_drag/LiftDrag.cc``):

* uuv_simulator: ``<link_name>``, ``<joint_name>``, ``<liftdrag>`` of ``<type>`` ``Quadratic`` (``lift_constant``,
  ``drag_constant``) or ``TwoLines`` (``area``, ``fluid_density``, ``a0``, ``alpha_stall``, ``cla``, ``cla_stall``,
  ``cda``, ``cda_stall``; every one required, as the plugin requires them), ``<dynamics>`` (``FirstOrder``:
  ``timeConstant``). The angle command is clipped to the joint's limits (as ``FinPlugin::OnUpdate``). The velocity
  is the water's relative to the link (``current_velocity_topic``: the plant's current).
* Gazebo Sim: ``<link_name>`` and the tags of :class:`uvms.dynamics.thrusters.lift_drag.GzLiftDrag` with its defaults,
  ``<control_joint_name>``. It has no dynamics of its own (a joint controller turns the fin): the time constant is
  :data:`DEFAULT_TIME_CONSTANT` with a :class:`~uvms.errors.FinDefaultWarning`. Gazebo subtracts only a wind from the
  link's velocity, so the ocean current does not enter.

A LiftDrag on a link that no joint turns is a fixed lifting surface: its force enters the plant, its angle is 0.
"""

from __future__ import annotations

import math
import warnings
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from ...errors import FinDefaultWarning, ModelCheckError
from ...model.control_surfaces import fin_joint, fin_plugins, text
from .lift_drag import GzLiftDrag, UUVQuadratic, UUVTwoLines, _cross, gz_wrench, uuv_force

if TYPE_CHECKING:
    from ...robot.robot import Robot

#: [s] the time constant of a fin whose plugin gives none (Gazebo Sim's LiftDrag; a uuv fin plugin without FirstOrder
#: dynamics): a hobby/AUV servo turning 20 degrees in about 0.1 s.
DEFAULT_TIME_CONSTANT = 0.1
#: uuv_simulator's lift-and-drag types and their required tags (``LiftDragModel.cc``: each ``create`` needs them all).
UUV_TYPES = {"Quadratic": ("lift_constant", "drag_constant"),
             "TwoLines": ("area", "fluid_density", "a0", "alpha_stall", "cla", "cla_stall", "cda", "cda_stall")}
#: Gazebo Sim LiftDrag tags read as numbers, by the field of GzLiftDrag they set.
GZ_NUMBERS = {"a0": "a0", "cla": "cla", "cda": "cda", "cma": "cma", "alpha_stall": "alpha_stall",
              "cla_stall": "cla_stall", "cda_stall": "cda_stall", "cma_stall": "cma_stall", "cm_delta": "cm_delta",
              "air_density": "rho", "area": "area", "control_joint_rad_to_cl": "control_joint_rad_to_cl"}
#: [rad] step of the central difference of a fin's wrench in its angle (the lift is linear in the angle below the
#: stall; the difference is exact for it and for a drag even in the angle).
ANGLE_STEP = 1e-4


@dataclass(frozen=True)
class Fin:
    """One fin: where it is on the vehicle, how it turns and what lift and drag it makes.

    Attributes:
        name: its plugin's name (a Gazebo Sim LiftDrag's link: gz names each by its class); kind: ``uuv_fin`` or
            ``gz_lift_drag``; link: the link the force acts on.
        joint: the joint that turns it, or None (a fixed lifting surface).
        model: the lift-and-drag parameters (:mod:`uvms.dynamics.thrusters.lift_drag`).
        lower, upper: the angle's range [rad] (the joint's limits; 0, 0 for a fixed surface).
        held: the angle [rad] the kinematic model holds the joint at (0, or the limit nearest).
        time_constant: tau [s] of delta' = (delta_cmd - delta) / tau.
        rotation: (3, 3) the link's orientation in the vehicle's base frame at ``held``; position: (3,) [m] its origin.
        axis: (3,) unit joint axis in the link frame; rotates: whether the joint turns the link (and the force).
        centre: (3,) [m] where uuv_simulator applies the force: the link's centre of mass, link frame.
    """

    name: str
    kind: str
    link: str
    joint: str | None
    model: UUVQuadratic | UUVTwoLines | GzLiftDrag
    lower: float
    upper: float
    held: float
    time_constant: float
    rotation: np.ndarray
    position: np.ndarray
    axis: np.ndarray
    rotates: bool
    centre: np.ndarray

    @property
    def moves(self) -> bool:
        """Whether its angle is an actuator (a range wider than nothing)."""
        return self.upper - self.lower > 1e-9

    @property
    def allocation_bounds(self) -> tuple[float, float]:
        """(lower, upper) [rad] the allocation may ask: the joint's limits, within the stall angle of a Gazebo LiftDrag
        whose link turns (its angle of attack grows with the angle; past the stall the lift falls)."""
        if self.kind == "gz_lift_drag" and self.rotates:
            stall = self.model.alpha_stall
            return max(self.lower, -stall), min(self.upper, stall)
        return self.lower, self.upper

    def wrench(self, twist: np.ndarray, current: np.ndarray, angle: float) -> np.ndarray:
        """The body wrench (6,) [N, N m] at the base frame origin (FLU) of this fin at ``angle`` [rad].

        Args:
            twist: the base's body twist (6,) [m/s, rad/s] in the base frame; current: the water's velocity (3,) [m/s]
                in the base frame (used by uuv_simulator's fin only, as its plugin).
        """
        rotation = self.rotation
        if self.rotates and angle != self.held:
            rotation = rotation @ pin.exp3(self.axis * (angle - self.held))
        velocity, angular = twist[:3] + _cross(twist[3:], self.position), twist[3:]
        if self.kind == "uuv_fin":
            normal = rotation[:, 2]
            relative = velocity - current
            in_plane = relative - (relative @ normal) * normal
            force = rotation @ uuv_force(self.model, rotation.T @ in_plane)
            point = self.position + rotation @ self.centre
            return np.concatenate([force, _cross(point, force)])
        force, torque = gz_wrench(self.model, rotation, velocity, angular, angle)
        return np.concatenate([force, torque + _cross(self.position, force)])


@dataclass(frozen=True)
class Fins:
    """The fins of a vehicle, in order (the order of the angles delta (m,)).

    Attributes:
        items: the fins; source: where they were read (for messages).
    """

    items: tuple[Fin, ...] = ()
    source: str = "<none>"

    def __len__(self) -> int:
        return len(self.items)

    @property
    def names(self) -> list[str]:
        """The fins' names (their plugins'), in order."""
        return [fin.name for fin in self.items]

    @property
    def lower(self) -> np.ndarray:
        """(m,) lower angles [rad]."""
        return np.array([fin.lower for fin in self.items])

    @property
    def upper(self) -> np.ndarray:
        """(m,) upper angles [rad]."""
        return np.array([fin.upper for fin in self.items])

    @property
    def held(self) -> np.ndarray:
        """(m,) the angles [rad] at rest (the kinematic model's)."""
        return np.array([fin.held for fin in self.items])

    @property
    def time_constants(self) -> np.ndarray:
        """(m,) first-order time constants [s]."""
        return np.array([fin.time_constant for fin in self.items])

    def wrench(self, twist: np.ndarray, current: np.ndarray, angles: np.ndarray) -> np.ndarray:
        """The fins' body wrench (6,) [N, N m] at the base frame (FLU) at ``angles`` (m,) [rad] (:meth:`Fin.wrench`)."""
        total = np.zeros(6)
        for fin, angle in zip(self.items, angles):
            total += fin.wrench(twist, current, float(angle))
        return total

    def linearized(self, twist: np.ndarray, current: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The fins' wrench about their rest angles: (w0 (6,) [N, N m] at rest, columns (6, m) [N/rad, N m/rad])
        with wrench(delta) ~ w0 + columns (delta - held); a fixed surface's column is zero. At low angles the lift
        is the angle times the speed squared: the columns scale with u^2 (:data:`ANGLE_STEP`)."""
        rest = self.held
        offset = self.wrench(twist, current, rest)
        columns = np.zeros((6, len(self)))
        for index, fin in enumerate(self.items):
            if fin.moves:
                up = fin.wrench(twist, current, fin.held + ANGLE_STEP)
                down = fin.wrench(twist, current, fin.held - ANGLE_STEP)
                columns[:, index] = (up - down) / (2.0 * ANGLE_STEP)
        return offset, columns

    def saturate(self, command: np.ndarray) -> np.ndarray:
        """The angle command (m,) clipped to the joints' limits [rad] (as FinPlugin clips its input)."""
        return np.clip(command, self.lower, self.upper)

    def rate(self, angles: np.ndarray, saturated_command: np.ndarray) -> np.ndarray:
        """delta' (m,) [rad/s] = (sat(delta_cmd) - delta) / tau."""
        return (saturated_command - angles) / self.time_constants


# ------------------------------------------------------------------ reading the plugins of a loaded robot
def fins_of(robot: Robot) -> Fins:
    """The fins of a loaded Robot's URDF (its fin plugins; none: an empty Fins).

    Raises:
        ModelCheckError: a plugin without ``link_name`` or naming no link of the model, a fin on an arm link, an
            unknown or incomplete uuv ``<liftdrag>``, a value that is not a number, a range without 0.

    Warns:
        FinDefaultWarning: fins given :data:`DEFAULT_TIME_CONSTANT`; a fin plugin whose joint moves as an arm joint.
    """
    root = robot.urdf_root
    if root is None:
        return Fins((), source=f"{robot.source} (no URDF)")
    joints = {joint.get("name"): joint for joint in root.findall("joint")}
    links = {link.get("name"): link for link in root.findall("link")}
    moving = {name: joint for name, joint in joints.items() if joint.get("type") in ("revolute", "continuous",
                                                                                      "prismatic")}
    items, defaulted = [], []
    for plugin, kind in fin_plugins(root):
        where = f"{robot.source}: fin plugin {plugin.get('name', '')!r}"
        link = text(plugin, "link_name")
        if link not in links:
            raise ModelCheckError(f"{where}: <link_name> {link!r} is not a link of the model; a fin plugin names the "
                                  f"link its lift and drag act on")
        joint = fin_joint(plugin, kind, {**moving, **_frozen_revolute(joints, robot)})[0]
        joint_class = robot.joint_classes.get(joint) if joint is not None else None
        if joint is not None and (joint_class is None or joint_class.kind != "fin"):
            warnings.warn(f"{where}: its joint {joint!r} moves as an arm joint (arm_joints names it), so its lift "
                          "and drag are not modelled; leave the joint out of arm_joints to make it a fin",
                          FinDefaultWarning, stacklevel=2)
            continue
        lower, upper = joint_class.limits if joint_class is not None and joint_class.limits else (0.0, 0.0)
        held = joint_class.value if joint_class is not None else 0.0
        if not lower <= 0.0 <= upper:
            raise ModelCheckError(f"{where}: the limits [{lower:g}, {upper:g}] rad of {joint!r} exclude 0; a fin's "
                                  "range holds its neutral angle 0")
        model, tau = (_uuv_model(plugin, where) if kind == "uuv_fin"
                      else (_gz_model(plugin, where), None))
        name = (plugin.get("name", "") if kind == "uuv_fin" else "") or link  # gz names every LiftDrag by its class
        if tau is None and upper > lower:
            tau = DEFAULT_TIME_CONSTANT
            defaulted.append(name)
        rotation, position = _placement(robot, link, where)
        axis, rotates = _axis(joints, joint, link)
        items.append(Fin(name=name, kind=kind, link=link, joint=joint, model=model,
                         lower=float(lower), upper=float(upper), held=float(held),
                         time_constant=DEFAULT_TIME_CONSTANT if tau is None else tau, rotation=rotation,
                         position=position, axis=axis, rotates=rotates, centre=_centre(links[link])))
    if defaulted:
        warnings.warn(f"{robot.source}: fin(s) {', '.join(defaulted)} take uvms's default time constant "
                      f"{DEFAULT_TIME_CONSTANT:g} s: their plugin gives no first-order time constant (Gazebo Sim's "
                      "LiftDrag has no dynamics: a joint controller turns the fin; a uuv fin plugin gives one with "
                      "<dynamics><type>FirstOrder</type><timeConstant>)", FinDefaultWarning, stacklevel=2)
    return Fins(tuple(items), source=robot.source)


def _frozen_revolute(joints: dict, robot: Robot) -> dict:
    """The joints uvms froze as fins, as revolute joints again (the plugins name them; the URDF now says fixed)."""
    frozen = {}
    for name, joint_class in robot.joint_classes.items():
        if joint_class.kind == "fin" and name in joints:
            element = ET.Element("joint", {"name": name, "type": "revolute"})
            element.extend(list(joints[name]))
            frozen[name] = element
    return frozen


def _number(plugin: ET.Element, tag: str, where: str, default: float | None = None) -> float:
    """A finite number of ``<tag>`` (``default`` when absent; None: required)."""
    raw = plugin.findtext(tag)
    if raw is None:
        if default is None:
            raise ModelCheckError(f"{where}: <{tag}> is missing")
        return default
    try:
        value = float(raw.strip())
    except ValueError:
        raise ModelCheckError(f"{where}: <{tag}> must be a number, got {raw.strip()!r}") from None
    if not math.isfinite(value):
        raise ModelCheckError(f"{where}: <{tag}> must be a finite number, got {raw.strip()!r}")
    return value


def _vector(plugin: ET.Element, tag: str, default: tuple, where: str) -> tuple[float, float, float]:
    raw = plugin.findtext(tag)
    if raw is None:
        return default
    try:
        values = tuple(float(x) for x in raw.split())
    except ValueError:
        values = ()
    if len(values) != 3 or not all(math.isfinite(x) for x in values):
        raise ModelCheckError(f"{where}: <{tag}> must be 3 numbers, got {raw.strip()!r}")
    return values


def _uuv_model(plugin: ET.Element, where: str) -> tuple[UUVQuadratic | UUVTwoLines, float | None]:
    """uuv_simulator's <liftdrag> and the FirstOrder time constant [s] (None: the plugin gives none)."""
    liftdrag = plugin.find("liftdrag")
    kind = (liftdrag.findtext("type") or "").strip() if liftdrag is not None else ""
    if kind not in UUV_TYPES:
        raise ModelCheckError(f"{where}: <liftdrag><type> {kind!r} is not a lift-and-drag model of uuv_simulator's "
                              f"fin plugin; valid: {', '.join(UUV_TYPES)} (LiftDragModel.cc)")
    values = [_number(liftdrag, tag, f"{where} <liftdrag> {kind}") for tag in UUV_TYPES[kind]]
    model = UUVQuadratic(*values) if kind == "Quadratic" else UUVTwoLines(*values)
    tau = None
    if (plugin.findtext("dynamics/type") or "").strip() == "FirstOrder" and plugin.find("dynamics/timeConstant") \
            is not None:
        tau = _number(plugin, "dynamics/timeConstant", where)
        if not tau > 0:
            raise ModelCheckError(f"{where}: the FirstOrder timeConstant must be > 0 s, got {tau:g}")
    return model, tau


def _gz_model(plugin: ET.Element, where: str) -> GzLiftDrag:
    """Gazebo Sim's LiftDrag parameters, the defaults of LiftDrag.cc for the tags left out."""
    defaults = GzLiftDrag()
    numbers = {field: _number(plugin, tag, where, getattr(defaults, field)) for tag, field in GZ_NUMBERS.items()}
    flags = {tag: text(plugin, tag).lower() in ("1", "true") for tag in ("radial_symmetry", "reversible")}
    vectors = {tag: _vector(plugin, tag, getattr(defaults, tag), where) for tag in ("cp", "forward", "upward")}
    return GzLiftDrag(**numbers, **flags, **vectors, control_joint=bool(text(plugin, "control_joint_name")))


def _placement(robot: Robot, link: str, where: str) -> tuple[np.ndarray, np.ndarray]:
    """The link frame's (rotation (3, 3), origin (3,) [m]) in the vehicle's base frame; the link must be fixed to it."""
    model = robot.model
    base = model.frames[model.getFrameId(robot.root_link)]
    frame = model.frames[model.getFrameId(link)]
    if frame.parentJoint != base.parentJoint:
        raise ModelCheckError(f"{where}: its link {link!r} moves with joint {model.names[frame.parentJoint]!r}; a fin "
                              f"must be fixed to the vehicle body ({robot.root_link!r}) but for its own joint")
    placement = base.placement.actInv(frame.placement)
    return placement.rotation.copy(), placement.translation.copy()


def _axis(joints: dict, joint: str | None, link: str) -> tuple[np.ndarray, bool]:
    """The fin joint's unit axis in its child link's frame, and whether that child is the plugin's link."""
    if joint is None:
        return np.array([0.0, 0.0, 1.0]), False
    element = joints[joint].find("axis")
    axis = np.array([float(x) for x in (element.get("xyz", "1 0 0") if element is not None else "1 0 0").split()])
    norm = float(np.linalg.norm(axis))
    rotates = joints[joint].find("child").get("link") == link
    return (axis / norm if norm > 0 else np.array([0.0, 0.0, 1.0])), rotates


def _centre(link: ET.Element) -> np.ndarray:
    """The link's centre of mass [m] in its frame (its <inertial><origin>; 0 without)."""
    origin = link.find("inertial/origin")
    return np.array([float(x) for x in origin.get("xyz", "0 0 0").split()]) if origin is not None else np.zeros(3)
