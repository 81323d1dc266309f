"""What a Pinocchio model's structure says before it is a Robot: the kind of base, the joints as uvms shows
them, what each joint of the model file is (:class:`JointClass`), and the default end effectors with the rule
that chose them."""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np
import pinocchio as pin

#: Kinds of joint: "arm" (commanded), "mimic" (follows an arm joint, adds no degree of freedom), and the kinds
#: uvms freezes (writes as fixed joints into the URDF Pinocchio builds): "propeller", "fin" (a control surface: its
#: angle is an actuator of the actuated plant), "sensor", "fixed by range" and "frozen" (left out of ``arm_joints=``).
JOINT_KINDS = ("arm", "mimic", "propeller", "fin", "sensor", "fixed by range", "frozen")

#: Words of the link and joint names of uuv_simulator's sensor macros (uuv_sensor_ros_plugins/urdf/*.xacro: dvl,
#: dvl_sonarN, imu, pressure, camera and camera_link_optical, sonar (multibeam and side-scan), gps, magnetometer,
#: rpt, pose_sensor, cc_sensor (the cpc plugin), duo3d) and of other common sensor frames. A name matches when
#: one of its words (split at / _ - . with trailing digits dropped: "dvl_sonar0_link" -> dvl, sonar, link) is one.
SENSOR_WORDS = frozenset({"dvl", "imu", "pressure", "camera", "optical", "sonar", "gps", "magnetometer", "rpt",
                          "mbes", "cpc", "sensor", "duo3d", "usbl", "altimeter", "lidar", "laser"})

#: Names of an end-effector frame, in order of preference: the name itself or ``*_<name>``.
EE_NAMES = ("end_effector", "tool", "tcp", "ee")
#: ``robot.ee_reason`` of end effectors given by the caller (``ee=``).
EE_GIVEN = "given (ee=)"


@dataclass(frozen=True)
class JointInfo:
    """One joint of the model, as `uvms info` shows it."""

    name: str
    kind: str  # Pinocchio short name, e.g. "JointModelRZ"
    nq: int
    nv: int
    idx_q: int
    idx_v: int
    lower: np.ndarray  # (nq,) [rad or m]
    upper: np.ndarray  # (nq,)
    is_vehicle: bool


@dataclass(frozen=True)
class JointClass:
    """What a (non-vehicle, non-fixed) joint of the model file is to uvms, and why.

    Attributes:
        kind: one of :data:`JOINT_KINDS`.
        reason: why, one line (``uvms info`` prints it).
        value: the value the joint is held at [rad or m] when it is frozen (written as a fixed joint, its motion
            at that value folded into its origin); None when it moves.
        limits: the file's (lower, upper) [rad] of a fin (the range of its angle, an actuator), else None.
    """

    kind: str
    reason: str
    value: float | None = None
    limits: tuple[float, float] | None = None

    @property
    def frozen(self) -> bool:
        """Whether the joint is held (a fixed joint in the Pinocchio model)."""
        return self.value is not None


def base_type_of(model: pin.Model) -> str:
    """"floating", "planar" or "fixed", from the first joint of a Pinocchio model."""
    if model.njoints > 1 and model.parents[1] == 0:
        shortname = model.joints[1].shortname()
        if shortname == "JointModelFreeFlyer":
            return "floating"
        if shortname == "JointModelPlanar":
            return "planar"
    return "fixed"


def vehicle_joint_index(model: pin.Model) -> int:
    """Index of the vehicle joint (1), or 0 (the universe) for a fixed base."""
    return 0 if base_type_of(model) == "fixed" else 1


def joint_infos(model: pin.Model) -> list[JointInfo]:
    """Every joint but Pinocchio's universe, vehicle first."""
    vehicle = vehicle_joint_index(model)
    infos = []
    for index in range(1, model.njoints):
        joint = model.joints[index]
        span = slice(joint.idx_q, joint.idx_q + joint.nq)
        infos.append(JointInfo(
            name=model.names[index], kind=joint.shortname(), nq=joint.nq, nv=joint.nv,
            idx_q=joint.idx_q, idx_v=joint.idx_v,
            lower=model.lowerPositionLimit[span].copy(), upper=model.upperPositionLimit[span].copy(),
            is_vehicle=(index == vehicle),
        ))
    return infos


def unit_norm_slices(joints: list[JointInfo]) -> list[tuple[str, slice]]:
    """Parts of q that must have unit norm: quaternions and (cos, sin) pairs, with the name of their joint."""
    slices = []
    for joint in joints:
        end = joint.idx_q + joint.nq
        if joint.kind in ("JointModelFreeFlyer", "JointModelSpherical"):
            slices.append((joint.name, slice(end - 4, end)))
        elif joint.nq == joint.nv + 1:  # planar and continuous joints hold (cos, sin)
            slices.append((joint.name, slice(end - 2, end)))
    return slices


def joint_class_table(model: pin.Model, given: Mapping[str, JointClass] | None = None) -> Mapping[str, JointClass]:
    """The classes of the model file's joints (``given``, from ``uvms.load``), completed by the moving joints of the
    model that ``given`` does not name (a Robot built from a Pinocchio model): arm joints, or mimics.

    Returns:
        {joint name: JointClass}, read-only.
    """
    table = dict(given or {})
    vehicle = vehicle_joint_index(model)
    for index in range(1, model.njoints):
        name = model.names[index]
        if index != vehicle and name not in table:
            mimic = model.joints[index].shortname() == "JointModelMimic"
            table[name] = JointClass("mimic" if mimic else "arm", "a moving joint of the Pinocchio model")
    return MappingProxyType(table)


def sensor_word(name: str) -> str | None:
    """The word of :data:`SENSOR_WORDS` in a link or joint name ("rexrov/dvl_sonar0_link" -> "dvl"), or None."""
    for word in re.split(r"[/_\-.]+", name.lower()):
        if word.rstrip("0123456789") in SENSOR_WORDS:
            return word.rstrip("0123456789")
    return None


def ee_name(name: str) -> str | None:
    """The entry of :data:`EE_NAMES` that a frame name is (or ends with after '_' or a ROS namespace '/'), or None."""
    return next((stem for stem in EE_NAMES if name == stem or name.endswith(("_" + stem, "/" + stem))), None)


def default_end_effectors(model: pin.Model) -> tuple[list[str], str]:
    """One end effector per arm, and the rule that chose each.

    An arm is the subtree of moving joints (mimics included) below a joint that hangs from the vehicle (or the
    world, for a fixed base). On each arm (in the order of the model's joints): the link or operational frame
    named like an end effector (:data:`EE_NAMES`, first match in that order, the last such frame of the arm),
    else the arm's last leaf link; never a link named like a sensor (:func:`sensor_word`) or below one. The
    vehicle's propellers and sensors hang from the vehicle body, never from an arm. A model without arm joints
    gets the vehicle's root link.

    Returns:
        (frame names, the rule that chose them, one line).
    """
    vehicle = vehicle_joint_index(model)
    arms: dict[int, set[int]] = {}
    for index in range(1, model.njoints):
        if index == vehicle:
            continue
        root = index
        while model.parents[root] not in (0, vehicle):
            root = model.parents[root]
        arms.setdefault(root, set()).add(index)
    chosen, reasons = [], []
    for root, joints in sorted(arms.items()):
        picked = arm_end_effector(model, joints)
        if picked is not None:
            chosen.append(picked[0])
            reasons.append(f"{picked[0]!r} {picked[1]} on the arm of joint {model.names[root]!r}")
    if chosen:
        return chosen, "; ".join(reasons)
    bodies = [f.name for f in model.frames if f.type == pin.FrameType.BODY and f.parentJoint == vehicle]
    link = bodies[0] if bodies else model.frames[-1].name
    return [link], f"{link!r}, the vehicle's root link: the model has no arm joint"


def arm_end_effector(model: pin.Model, joints: set[int]) -> tuple[str, str] | None:
    """The end effector of the arm made of ``joints`` (see :func:`default_end_effectors`) and why, or None."""
    candidates = [index for index, frame in enumerate(model.frames)
                  if frame.parentJoint in joints and frame.type in (pin.FrameType.BODY, pin.FrameType.OP_FRAME)
                  and not below_sensor(model, index)]
    for stem in EE_NAMES:
        named = [index for index in candidates if ee_name(model.frames[index].name) == stem]
        if named:
            return model.frames[named[-1]].name, f"(named like an end effector: {stem!r} or '*_{stem}')"
    parents = {model.frames[index].parentFrame for index in candidates}
    leaves = [index for index in candidates if model.frames[index].type == pin.FrameType.BODY and index not in parents]
    if not leaves:
        return None
    return model.frames[leaves[-1]].name, f"(its last leaf link; no frame is named {', '.join(EE_NAMES)} or *_NAME)"


def below_sensor(model: pin.Model, index: int) -> bool:
    """Whether a frame or a fixed link or joint between it and its moving joint is named like a sensor."""
    while index > 0 and model.frames[index].type != pin.FrameType.JOINT:
        if sensor_word(model.frames[index].name):
            return True
        index = model.frames[index].parentFrame
    return False
