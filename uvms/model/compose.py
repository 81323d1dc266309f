"""Composition: mount an arm model on a vehicle model as one Pinocchio model (``appendModel``) and one URDF."""

from __future__ import annotations

import os
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import pinocchio as pin

from ..errors import FrameNotFound, JointOrderWarning, UVMSError
from ..robot import urdf_export
from ..robot.conventions import pose_from_xyzrpy
from ..robot.robot import Robot
from ..robot.structure import EE_GIVEN, default_end_effectors
from . import checks, point_masses, resources
from .joint_classes import classify_joints
from .loader import build_model, captured_stderr, read_model_text, warn_missing_meshes
from .packages import package_index


def mount_arm(
    vehicle: Robot,
    arm: str | os.PathLike,
    *,
    parent_frame: str | None = None,
    placement: pin.SE3 | Sequence[float] | None = None,
    prefix: str = "arm_",
    ee: str | Sequence[str] | None = None,
    args: dict | None = None,
) -> Robot:
    """Mount an arm on a vehicle: one Pinocchio model (``pin.appendModel``) and its composed URDF.

    Args:
        vehicle: the vehicle (any Robot; its base type is kept).
        arm: an example-robot-data robot name (``"panda"``, ``"ur5"``, ``"z1"``),
            a shipped model name, or a ``.urdf``/``.xacro`` path. Mounted fixed to the vehicle,
            whatever its root link carries.
        parent_frame: frame of the vehicle the arm's root link is attached to; default: the
            vehicle's root link (``vehicle.root_link``, the link its floating/planar joint carries).
        placement: pose of the arm's root link in ``parent_frame``: a ``pin.SE3`` or
            [x, y, z, roll, pitch, yaw] [m, rad]; default identity.
        prefix: prepended to every link, joint and material name of the arm, so names never clash.
        ee: end-effector frame(s) of the result (names after prefixing); default: the rule of
            ``uvms.load`` on the composed model (one per arm: the vehicle's arms, then the mounted one), which
            ``uvms.load`` of the saved URDF gives again; when the vehicle's end effectors were given
            (``ee=``), those, then the arm's default one (the arm's first when the vehicle has no arm joints).
        args: xacro args of the arm file.

    Returns:
        A new Robot, its joints in Pinocchio's depth-first order: mounted on the vehicle's root
        link, the vehicle joint, the vehicle's arm joints, then the mounted arm's.
        The arm's joints are classified as ``uvms.load`` does (``joint_classes``: propellers, sensors and
        zero-range joints frozen, mimic chains composed).
        Its ``urdf`` is the vehicle's URDF plus the prefixed links, joints and materials of the arm
        (mesh files by absolute path) and a fixed joint ``<prefix>mount`` at ``placement``;
        ``robot.save_urdf(path)`` writes it, and ``uvms.load`` of that file gives the same links,
        joints, masses and poses (joints in Pinocchio's order: depth first, sibling joints by name,
        the same as here when the arm hangs from the vehicle's root link: the mount joint's name
        is then made to sort after its siblings; a mount elsewhere that reorders them gives a
        :class:`JointOrderWarning`).

    Raises:
        FrameNotFound: an unknown ``parent_frame`` (the suggestions include the vehicle's root link).
        UVMSError: an arm with a floating/planar root, names that clash, a bad placement.
    """
    path = arm_source(arm)
    packages = package_index(model=path)
    xml, origin, base_dir = read_model_text(path, args, packages=packages)
    robot_element = checks.parse_urdf(xml, origin)
    tree = checks.check_urdf(robot_element, origin)
    if tree.base_type != "fixed":
        raise UVMSError(f"{origin}: an arm to mount must have a fixed root, but its root joint is {tree.base_type}")
    warn_missing_meshes(robot_element, base_dir, packages, origin)
    classified = classify_joints(prefix_names(robot_element, prefix), origin, base_dir)
    arm_model = build_model(classified.urdf, "fixed", tree, origin)
    clashes = sorted(set(vehicle.frame_names) & {f.name for f in arm_model.frames} - {"universe"})
    if clashes:
        raise UVMSError(f"names of the arm clash with the vehicle's: {', '.join(clashes[:5])}; pass another prefix=")
    if parent_frame is None:
        parent_frame = vehicle.root_link
    if not isinstance(parent_frame, str) or not vehicle.model.existFrame(parent_frame):
        raise FrameNotFound(str(parent_frame), vehicle.frame_names, first=[vehicle.root_link])
    placement = placement_of(placement)
    parent_id = vehicle.frame_id(parent_frame)
    model = pin.appendModel(vehicle.model, arm_model, parent_id, placement)
    model.name = f"{vehicle.name}+{Path(origin).stem}"
    point_masses.check_mass_matrix(model, tree.point_masses, origin)  # an arm's point masses, now on a vehicle
    if ee is None and vehicle.ee_reason == EE_GIVEN:
        arm_ees = default_end_effectors(arm_model)[0]
        ee = vehicle.ee_frames + arm_ees if vehicle.n_arm else arm_ees + vehicle.ee_frames
    urdf = None
    if vehicle.urdf is not None:
        arm_element = ET.fromstring(classified.urdf)
        urdf = composed_urdf(vehicle, parent_id, placement, arm_element, base_dir, f"{prefix}mount", packages)
        check_joint_order(model, urdf, vehicle)
    return Robot(model, ee=ee, name=model.name, source=f"{vehicle.source} + {origin}", urdf=urdf,
                 base_reason=vehicle.base_reason, packages={**packages, **vehicle.packages},
                 joint_classes={**vehicle.joint_classes, **classified.classes})


def check_joint_order(model: pin.Model, urdf: str, vehicle: Robot) -> None:
    """Build the saved form of the composed URDF and warn when its joints come in another order than the model's.

    Raises:
        UVMSError: Pinocchio cannot build the composed URDF.
    """
    vehicle_joint = vehicle.model.names[1] if vehicle.base_type != "fixed" else None
    text = urdf_export.self_describing_urdf(urdf, vehicle.base_type, vehicle_joint, "<composed>")
    with captured_stderr():
        try:
            parsed = pin.buildModelFromXML(text, mimic=True)
        except (RuntimeError, ValueError) as exc:
            raise UVMSError(f"the composed URDF of {model.name} does not build: {' '.join(str(exc).split())}") from None
    if list(parsed.names) != list(model.names):
        warnings.warn(
            f"{model.name}: uvms.load of its saved URDF orders the joints {list(parsed.names)[1:]} (Pinocchio takes "
            f"sibling joints by name) instead of {list(model.names)[1:]}; map configurations by joint name, or mount "
            "the arm on the vehicle's root link (the default parent_frame)", JointOrderWarning, stacklevel=3)


def placement_of(placement: pin.SE3 | Sequence[float] | None) -> pin.SE3:
    """A placement given as a ``pin.SE3``, [x, y, z, roll, pitch, yaw] [m, rad] or None (identity).

    Raises:
        UVMSError: not 6 finite numbers.
    """
    if placement is None:
        return pin.SE3.Identity()
    if isinstance(placement, pin.SE3):
        return placement
    try:
        values = np.asarray(placement, dtype=float)
    except (TypeError, ValueError):
        values = np.zeros(0)
    if values.shape != (6,) or not np.all(np.isfinite(values)):
        raise UVMSError("placement must be a pin.SE3 or 6 finite numbers [x, y, z, roll, pitch, yaw]")
    return pose_from_xyzrpy(values)


def composed_urdf(
    vehicle: Robot, parent_id: int, placement: pin.SE3, arm: ET.Element, arm_dir: Path | None, mount: str,
    arm_packages: Mapping[str, Path],
) -> str:
    """The vehicle's URDF with the (prefixed) arm attached by a fixed joint ``mount``, meshes by absolute path.

    The joint's parent is a link of the vehicle on the same Pinocchio joint as the parent frame (the
    frame's own link when it is one), its origin the placement expressed in that link.
    """
    document = ET.fromstring(vehicle.urdf)
    document.set("name", f"{document.get('name', vehicle.name)}+{arm.get('name', 'arm')}")
    vehicle_dir = Path(vehicle.source).parent if Path(vehicle.source).is_file() else None
    absolute_meshes(document, vehicle_dir, vehicle.packages)
    absolute_meshes(arm, arm_dir, arm_packages)
    frame = vehicle.model.frames[parent_id]
    link_names = {link.get("name") for link in document.findall("link")}
    if frame.type == pin.FrameType.BODY and frame.name in link_names:
        link, in_link = frame.name, placement
    else:  # a joint or other frame: the first link on the same Pinocchio joint
        body = next(f for f in vehicle.model.frames if f.type == pin.FrameType.BODY and f.name in link_names
                    and f.parentJoint == frame.parentJoint)
        link, in_link = body.name, body.placement.actInv(frame.placement * placement)
    taken = link_names | {j.get("name") for j in document.iter("joint")} | {e.get("name") for e in arm.iter()
                                                                             if e.tag in ("link", "joint")}
    siblings = [j.get("name", "") for j in document.findall("joint") if j.find("parent") is not None
                and j.find("parent").get("link") == link]
    while mount in taken or any(name >= mount for name in siblings):
        mount = "~" + mount  # Pinocchio orders sibling joints by name: the arm's come after the vehicle's
    children = {c.get("link") for c in arm.iter("child")}
    arm_root = next(iter({link.get("name") for link in arm.findall("link")} - children))
    for element in arm:
        if element.tag in ("link", "joint", "material"):
            document.append(element)
    if mount.startswith("~"):
        document.append(ET.Comment(" '~': sorted after the other joints of the parent link, so that uvms.load "
                                   "(Pinocchio orders sibling joints by name) keeps the arm's joints last "))
    joint = ET.SubElement(document, "joint", name=mount, type="fixed")
    ET.SubElement(joint, "origin", xyz=" ".join(f"{x:.17g}" for x in in_link.translation),
                  rpy=" ".join(f"{x:.17g}" for x in pin.rpy.matrixToRpy(in_link.rotation)))
    ET.SubElement(joint, "parent", link=link)
    ET.SubElement(joint, "child", link=arm_root)
    return ET.tostring(document, encoding="unicode")


def absolute_meshes(robot: ET.Element, base_dir: Path | None, packages: Mapping[str, Path]) -> None:
    """Replace every mesh URI that resolves (relative, ``file://``, ``package://``) by its absolute path."""
    for mesh in robot.iter("mesh"):
        found = resources.resolve_uri(mesh.get("filename", ""), base_dir, packages)
        if found is not None:
            mesh.set("filename", str(found.resolve()))


def arm_source(arm: str | os.PathLike) -> Path:
    """Path of an arm given as a file, a shipped model name or an example-robot-data name."""
    candidate = Path(arm)
    if candidate.is_file() or str(arm) in resources.shipped_models():
        return resources.resolve_model_path(arm)
    return resources.example_robot_urdf(str(arm))


def prefix_names(robot_element: ET.Element, prefix: str) -> str:
    """URDF text with ``prefix`` prepended to every link, joint and material name and reference.

    A joint that shares its name with a link gets a ``_joint`` suffix: Pinocchio
    would otherwise hold two frames of one name, which ``appendModel`` rejects.
    """
    for element in robot_element.iter():
        element.attrib.pop("_owner", None)  # annotations of uvms.model.checks
    links = {link.get("name") for link in robot_element.findall("link")}
    joint_names = {
        name: prefix + name + ("_joint" if name in links else "")
        for name in (joint.get("name") for joint in robot_element.iter("joint")) if name
    }
    for element in robot_element.iter():
        if element.tag == "link" and "name" in element.attrib:
            element.set("name", prefix + element.get("name"))
        elif element.tag == "joint" and "name" in element.attrib:
            element.set("name", joint_names[element.get("name")])
    for tag in ("parent", "child"):
        for element in robot_element.iter(tag):
            element.set("link", prefix + element.get("link"))
    for element in robot_element.iter("material"):  # definitions and references alike
        if element.get("name"):
            element.set("name", prefix + element.get("name"))
    for element in robot_element.iter("mimic"):
        element.set("joint", joint_names.get(element.get("joint"), element.get("joint")))
    return ET.tostring(robot_element, encoding="unicode")
