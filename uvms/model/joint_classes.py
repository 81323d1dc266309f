"""Which joints of a URDF a user commands, decided before Pinocchio builds the model.

Every joint that moves in the file (revolute, continuous, prismatic; the vehicle's floating/planar joint aside)
gets a class (:class:`uvms.robot.structure.JointClass`, ``robot.joint_classes``, printed by ``uvms info``):

* ``propeller``: it carries a thruster: a thruster plugin of a simulator uvms reads names it or its child link
  (:mod:`uvms.model.plugins`), the ``thrusters.yaml`` beside the model names its child link as a thruster's
  ``frame`` or ``parent``, or, with no plugin, its structure says so: a continuous joint to a leaf link named like
  a propeller, massless or tiny (:mod:`uvms.model.propellers`). A propeller's spin changes nothing uvms computes
  (kinematics; the thrust acts along the joint's axis, which stays in the URDF): it is frozen, its link's frame
  stays.
* ``fin``: a control surface: a uuv_simulator fin plugin or a Gazebo Sim LiftDrag turns it
  (:mod:`uvms.model.control_surfaces`). Frozen; its angle is an actuator of the actuated plant.
* ``sensor``: the joint or its child link is named like a sensor (:data:`uvms.robot.structure.SENSOR_WORDS`:
  the names of uuv_simulator's sensor macros), and the joint has a zero range (uuv_simulator mounts its sensors
  on revolute joints with limits [0, 0]) or its subtree carries no mass. Frozen.
* ``fixed by range``: any other revolute or prismatic joint with upper - lower <= :data:`RANGE_TOLERANCE`
  (a missing lower or upper is 0, as urdfdom reads it). Frozen.
* ``mimic``: a joint with ``<mimic>``. A chain (a mimics b, which mimics c) is composed to its root joint c:
  q_a = m1 q_b + o1 and q_b = m2 q_c + o2 give q_a = (m1 m2) q_c + (m1 o2 + o1), as Pinocchio needs. A mimic of
  a frozen joint is frozen at the value the relation gives. Pinocchio also needs the joint a group follows to come
  first in its order (depth first, sibling joints by name, as urdfdom stores them): when a mimic comes before its
  root (a finger ``finger_b`` beside the ``jaw`` it mimics), the relation is inverted and the group follows that
  earliest joint, which is then the one commanded (``uvms info`` says so).
* ``arm``: every other joint: what a user commands.

``arm_joints=[...]`` overrides the rule: exactly the listed joints move (class ``arm``); an arm joint left out
is frozen (class ``frozen``), the others keep their class. A frozen joint is held at 0, or at its limit nearest
to 0 when 0 is outside its limits (a zero range: at that value), and written ``type="fixed"`` in the URDF given
to Pinocchio: its motion at that value folded into its origin, its limit, dynamics, calibration,
safety_controller and mimic elements dropped, its axis kept (a thruster plugin's ``<jointName>`` reads it).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from ..errors import ModelCheckError, NameNotFound
from ..robot.structure import JointClass, sensor_word
from .control_surfaces import control_surface_joints
from .propellers import propeller_joints

#: [rad or m] a revolute or prismatic joint whose upper - lower limit is at most this cannot move.
RANGE_TOLERANCE = 1e-9
#: URDF joint types that move and are not a vehicle joint.
MOVING_TYPES = ("revolute", "continuous", "prismatic")
#: Children of a joint that a fixed joint does not have (its <axis> is kept: a thruster plugin reads it).
DROPPED_WHEN_FROZEN = ("limit", "dynamics", "calibration", "safety_controller", "mimic")


@dataclass(frozen=True)
class ClassifiedModel:
    """A URDF with its joints classified: the text Pinocchio builds and the classes with their reasons."""

    urdf: str
    classes: Mapping[str, JointClass]


@dataclass(frozen=True)
class Mimic:
    """A mimic joint's relation to the root of its chain: q = multiplier * q_root + offset."""

    root: str
    multiplier: float
    offset: float
    through: tuple[str, ...]  # the mimic joints between it and the root (empty: it mimics the root itself)


def classify_joints(
    xml: str, origin: str, model_dir: Path | None = None, arm_joints: Sequence[str] | None = None
) -> ClassifiedModel:
    """Classify the joints of a checked URDF (see the module docstring) and write the URDF Pinocchio builds.

    Args:
        xml: URDF text that passed :func:`uvms.model.checks.check_urdf`.
        origin: the file, for messages.
        model_dir: the model's folder, where a ``thrusters.yaml`` may name propeller links (None: a string).
        arm_joints: the joints that move (every other one frozen), or None for the rule.

    Returns:
        The URDF text (``xml`` itself when no joint is frozen and no mimic chain composed) and the classes, in the
        order of the file.

    Raises:
        ModelCheckError: a mimic of a missing or non-moving joint, a mimic cycle, an ``arm_joints`` entry that
            names a mimic or a joint without range.
        NameNotFound: an ``arm_joints`` entry that is not a joint of the file (the message lists the valid ones).

    Warns:
        ThrusterFileWarning: a ``thrusters.yaml`` beside the model that cannot be read.
    """
    robot = ET.fromstring(xml)
    joints = {joint.get("name"): joint for joint in robot.findall("joint")}
    moving = {name: joint for name, joint in joints.items() if joint.get("type") in MOVING_TYPES}
    mimics = composed_mimics(moving, joints, origin)
    masses = subtree_masses(robot)
    propellers = propeller_joints(robot, moving, model_dir, masses)
    limits = {name: joint_limits(joint) for name, joint in moving.items()}
    classes = {name: rule_class(name, joint, limits[name], propellers.get(name), masses)
               for name, joint in moving.items() if name not in mimics}
    classes.update({name: JointClass("fin", f"{why}; held at {held_value(limits[name]):g}", held_value(limits[name]),
                                     limits[name])  # frozen; its written limits: the range of the fin's angle
                    for name, why in control_surface_joints(robot, moving).items()
                    if name not in mimics and name not in propellers})
    if arm_joints is not None:
        classes = overridden(classes, arm_joints, mimics, limits, origin)
    mimics, leaders = leader_first(mimics, pinocchio_order(robot), origin, frozen=lambda root: classes[root].frozen)
    for leader, root in leaders.items():  # the joint commanded for the group; its own limits
        own = rule_class(leader, moving[leader], limits[leader], propellers.get(leader), masses)
        classes[leader] = JointClass(classes[root].kind, f"{own.reason}; commanded for {root!r}, which mimics it "
                                     f"(inverted: Pinocchio orders {leader!r} first)")
    for name, mimic in mimics.items():
        classes[name] = mimic_class(mimic, classes[mimic.root])
    classes = {name: classes[name] for name in moving}  # the file's order
    frozen = {name: joint_class.value for name, joint_class in classes.items() if joint_class.frozen}
    rewritten = {name: mimic for name, mimic in mimics.items()
                 if (mimic.through or name in leaders.values()) and name not in frozen}
    if not frozen and not rewritten:
        return ClassifiedModel(xml, classes)
    for name, value in frozen.items():
        freeze(moving[name], value)
    for leader in leaders:
        moving[leader].remove(moving[leader].find("mimic"))
    for name, mimic in rewritten.items():
        element = moving[name].find("mimic")
        element = ET.SubElement(moving[name], "mimic") if element is None else element
        element.attrib.update(joint=mimic.root, multiplier=repr(mimic.multiplier), offset=repr(mimic.offset))
    return ClassifiedModel(ET.tostring(robot, encoding="unicode"), classes)


# ------------------------------------------------------------------ the rule
def rule_class(name: str, joint: ET.Element, limits: tuple[float, float] | None, propeller: str | None,
               masses: Mapping[str, float]) -> JointClass:
    """The class of a joint that is not a mimic, by the rule of the module docstring.

    Args:
        name, joint: the joint; limits: its (lower, upper) [rad or m] or None; propeller: why it carries a
        thruster, or None; masses: {link: mass of its subtree [kg]}.
    """
    child = joint.find("child").get("link")
    named, word = next(((n, w) for n in (child, name) if (w := sensor_word(n))), (None, None))
    if propeller is not None:
        kind, why = "propeller", propeller
    elif is_zero_range(limits):
        kind, why = ("sensor", f"zero range {format_range(limits)}, {named!r} named like a sensor ({word})") if named \
            else ("fixed by range", f"limits {format_range(limits)}: upper - lower <= {RANGE_TOLERANCE:g}")
    elif named is not None and masses[child] == 0.0:
        kind, why = "sensor", f"{named!r} named like a sensor ({word}) and no mass below it"
    else:
        motion = joint.get("type") if limits is None else f"{joint.get('type')}, limits {format_range(limits)}"
        return JointClass("arm", motion)
    held = held_value(limits)
    return JointClass(kind, f"{why}; held at {held:g}", held)


def joint_limits(joint: ET.Element) -> tuple[float, float] | None:
    """(lower, upper) of a revolute/prismatic joint (a missing bound is 0, as urdfdom reads it); None when it has
    no <limit> or is continuous."""
    limit = joint.find("limit")
    if joint.get("type") == "continuous" or limit is None:
        return None
    return float(limit.get("lower", "0")), float(limit.get("upper", "0"))


def is_zero_range(limits: tuple[float, float] | None) -> bool:
    """Whether limits (lower, upper) leave no motion: upper - lower <= RANGE_TOLERANCE."""
    return limits is not None and limits[1] - limits[0] <= RANGE_TOLERANCE


def held_value(limits: tuple[float, float] | None) -> float:
    """Where a frozen joint is held [rad or m]: 0, or the limit nearest to 0 when 0 is outside the limits."""
    return 0.0 if limits is None else float(min(max(0.0, limits[0]), limits[1]))


def format_range(limits: tuple[float, float]) -> str:
    return f"[{limits[0]:g}, {limits[1]:g}]"


def subtree_masses(robot: ET.Element) -> dict[str, float]:
    """{link: mass [kg] of the link and every link below it}."""
    own = {}
    for link in robot.findall("link"):
        mass = link.find("inertial/mass")
        own[link.get("name")] = float(mass.get("value", "0")) if mass is not None else 0.0
    children: dict[str, list[str]] = {name: [] for name in own}
    for joint in robot.findall("joint"):
        children[joint.find("parent").get("link")].append(joint.find("child").get("link"))
    totals: dict[str, float] = {}
    order = [name for name in own]
    while order:  # children before parents, without recursion (a chain may be long)
        name = order[-1]
        pending = [child for child in children[name] if child not in totals]
        if pending:
            order.extend(pending)
            continue
        order.pop()
        totals[name] = own[name] + sum(totals[child] for child in children[name])
    return totals


# ------------------------------------------------------------------ mimics
def composed_mimics(moving: Mapping[str, ET.Element], joints: Mapping[str, ET.Element],
                    origin: str) -> dict[str, Mimic]:
    """{mimic joint: its relation to the root of its chain} of the moving joints with a ``<mimic>``.

    Raises:
        ModelCheckError: a mimic of a joint that does not exist or does not move, or a cycle.
    """
    direct = {}
    for name, joint in moving.items():
        element = joint.find("mimic")
        if element is not None:
            direct[name] = (element.get("joint", ""), float(element.get("multiplier", "1")),
                            float(element.get("offset", "0")))
    mimics = {}
    for name in direct:
        chain, multiplier, offset, leader = [name], 1.0, 0.0, name
        while leader in direct:
            target, m, o = direct[leader]
            multiplier, offset = multiplier * m, multiplier * o + offset  # q_a = m1 (m2 q_c + o2) + o1
            if target in chain:
                raise ModelCheckError(f"{origin}: mimic joints form a cycle ({' -> '.join([*chain, target])}); a "
                                      f"mimic chain must end at a joint without <mimic>")
            chain.append(target)
            leader = target
        if leader not in moving:
            what = "is not a joint of the model" if leader not in joints else f"is a {joints[leader].get('type')} joint"
            raise ModelCheckError(f"{origin}: joint {chain[-2]!r} mimics {leader!r}, which {what}; a mimic follows a "
                                  f"revolute, continuous or prismatic joint")
        mimics[name] = Mimic(leader, multiplier, offset, tuple(chain[1:-1]))
    return mimics


def pinocchio_order(robot: ET.Element) -> dict[str, int]:
    """{joint name: its rank in Pinocchio's model}: depth first, siblings by name (urdfdom's map, walked by
    Pinocchio)."""
    below: dict[str, list[tuple[str, str]]] = {}
    children = set()
    for joint in robot.findall("joint"):
        parent, child = joint.find("parent"), joint.find("child")
        if parent is not None and child is not None:
            below.setdefault(parent.get("link", ""), []).append((joint.get("name", ""), child.get("link", "")))
            children.add(child.get("link", ""))
    roots = [link.get("name", "") for link in robot.findall("link") if link.get("name") not in children]
    order: dict[str, int] = {}
    stack = [child for root in roots for child in sorted(below.get(root, []), reverse=True)]
    while stack:
        name, link = stack.pop()
        order[name] = len(order)
        stack.extend(sorted(below.get(link, []), reverse=True))
    return order


def leader_first(mimics: Mapping[str, Mimic], order: Mapping[str, int], origin: str,
                 frozen: Callable[[str], bool]) -> tuple[dict[str, Mimic], dict[str, str]]:
    """The mimic relations with every group following the joint Pinocchio meets first (see the module docstring):
    a root r after its mimic p (q_p = k q_r + o) gives q_r = q_p / k - o / k, q_i = (k_i / k) q_p + (o_i - k_i o / k).

    Returns:
        (the relations, {new leader: the root it replaces}).

    Raises:
        ModelCheckError: the earliest mimic of a group has a zero multiplier (the relation cannot be inverted).
    """
    groups: dict[str, list[str]] = {}
    for name, mimic in mimics.items():
        groups.setdefault(mimic.root, []).append(name)
    result, leaders = dict(mimics), {}
    for root, members in groups.items():
        leader = min(members, key=lambda name: order.get(name, len(order)))
        if frozen(root) or order.get(leader, len(order)) > order.get(root, len(order)):
            continue
        k, o = mimics[leader].multiplier, mimics[leader].offset
        if k == 0.0:
            raise ModelCheckError(f"{origin}: joint {leader!r} mimics {root!r} "
                                  "with multiplier 0 and comes before it in "
                                  "Pinocchio's order (depth first, siblings by name), which needs the followed joint "
                                  "first; give a non-zero multiplier or rename the joints")
        leaders[leader] = root
        del result[leader]
        result[root] = Mimic(leader, 1.0 / k, -o / k, ())
        for name in members:
            if name != leader:
                mimic = mimics[name]
                through = tuple(joint for joint in (*mimic.through, root) if joint != leader)
                result[name] = Mimic(leader, mimic.multiplier / k, mimic.offset - mimic.multiplier * o / k, through)
    return result, leaders


def mimic_class(mimic: Mimic, root: JointClass) -> JointClass:
    """The class of a mimic joint, frozen when the root of its chain is."""
    relation = f"q = {mimic.multiplier:g} q({mimic.root}) + {mimic.offset:g}"
    through = f" (composed through {', '.join(mimic.through)})" if mimic.through else ""
    if root.frozen:
        value = mimic.multiplier * root.value + mimic.offset
        return JointClass("mimic", f"follows {mimic.root!r}{through}, which is frozen ({root.kind}): {relation} "
                                   f"held at {value:g}", value)
    return JointClass("mimic", f"follows {mimic.root!r}{through}: {relation}")


# ------------------------------------------------------------------ arm_joints=
def overridden(classes: Mapping[str, JointClass], arm_joints: Sequence[str], mimics: Mapping[str, Mimic],
               limits: Mapping[str, tuple[float, float] | None], origin: str) -> dict[str, JointClass]:
    """The classes with exactly ``arm_joints`` moving (see the module docstring).

    Raises:
        ModelCheckError: ``arm_joints`` is not a list of names, or names a mimic or a joint without range.
        NameNotFound: a name that is not a moving joint of the file (the message lists the valid ones).
    """
    names = list(arm_joints) if isinstance(arm_joints, Iterable) and not isinstance(arm_joints, str) else None
    if names is None or not all(isinstance(name, str) for name in names):
        raise ModelCheckError(f"{origin}: arm_joints must be a list of joint names, got {arm_joints!r}")
    valid = [name for name in classes if not is_zero_range(limits[name])]
    for name in names:
        if name in mimics:
            raise ModelCheckError(f"{origin}: arm_joints names {name!r}, which mimics {mimics[name].root!r}: name "
                                  f"{mimics[name].root!r} instead (valid: {', '.join(valid)})")
        if name in classes and name not in valid:
            raise ModelCheckError(f"{origin}: arm_joints names {name!r}, which cannot move (limits "
                                  f"{format_range(limits[name])}); valid: {', '.join(valid)}")
        if name not in classes:
            raise NameNotFound("arm joint", name, valid, first=valid, where=f"{origin}: arm_joints")
    result = {}
    for name, joint_class in classes.items():
        if name in names:
            why = joint_class.reason.split("; held at")[0]
            rule = "" if joint_class.kind == "arm" else f" (by the rule a {joint_class.kind}: {why})"
            result[name] = JointClass("arm", f"named in arm_joints{rule}")
        elif joint_class.kind == "arm":
            value = held_value(limits[name])
            result[name] = JointClass("frozen", f"not in arm_joints: held at {value:g}", value)
        else:
            result[name] = joint_class
    return result


# ------------------------------------------------------------------ the URDF Pinocchio builds
def freeze(joint: ET.Element, value: float) -> None:
    """Make a joint fixed at ``value`` [rad or m]: its motion at that value folded into its origin, the children
    a fixed joint does not have dropped (:data:`DROPPED_WHEN_FROZEN`)."""
    kind = joint.get("type")
    joint.set("type", "fixed")
    for tag in DROPPED_WHEN_FROZEN:
        for element in joint.findall(tag):
            joint.remove(element)
    if value == 0.0:
        return
    axis_element = joint.find("axis")
    axis = np.array([float(x) for x in (axis_element.get("xyz", "1 0 0") if axis_element is not None
                                        else "1 0 0").split()])
    motion = (pin.SE3(np.eye(3), axis * value) if kind == "prismatic"
              else pin.SE3(pin.exp3(axis * value), np.zeros(3)))
    element = joint.find("origin")
    if element is None:
        element = ET.SubElement(joint, "origin")
    xyz = [float(x) for x in element.get("xyz", "0 0 0").split()]
    rpy = [float(x) for x in element.get("rpy", "0 0 0").split()]
    placement = pin.SE3(pin.rpy.rpyToMatrix(*rpy), np.array(xyz)) * motion
    element.set("xyz", " ".join(repr(float(x)) for x in placement.translation))
    element.set("rpy", " ".join(repr(float(x)) for x in pin.rpy.matrixToRpy(placement.rotation)))
