"""Composition: mount an arm model on a vehicle model as one Pinocchio model (``appendModel``)."""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pinocchio as pin

from . import checks, resources
from ..conventions import pose_from_xyzrpy
from ..errors import UVMSError
from .loader import build_model, read_model_text, warn_missing_meshes
from ..robot import Robot, default_end_effectors


def mount_arm(
    vehicle: Robot,
    arm: str | os.PathLike,
    *,
    parent_frame: str = "base_link",
    placement: pin.SE3 | Sequence[float] | None = None,
    prefix: str = "arm_",
    ee: str | Sequence[str] | None = None,
    args: dict | None = None,
) -> Robot:
    """Mount an arm on a vehicle, without writing a combined URDF.

    Args:
        vehicle: the vehicle (any Robot; its base type is kept).
        arm: an example-robot-data robot name (``"panda"``, ``"ur5"``, ``"z1"``),
            a shipped model name, or a ``.urdf``/``.xacro`` path. Loaded as a fixed-base arm.
        parent_frame: frame of the vehicle the arm's root link is attached to.
        placement: pose of the arm's root link in ``parent_frame``: a ``pin.SE3`` or
            [x, y, z, roll, pitch, yaw] [m, rad]; default identity.
        prefix: prepended to every link and joint name of the arm, so names never clash.
        ee: end-effector frame(s) of the result (names after prefixing); default:
            the vehicle's ``ee``-named frames plus the arm's default end effector.
        args: xacro args of the arm file.

    Returns:
        A new Robot: vehicle joints first, then the vehicle's arm joints, then the mounted arm's.
    """
    path = arm_source(arm)
    xml, origin, base_dir = read_model_text(path, args)
    robot_element = checks.parse_urdf(xml, origin)
    tree = checks.check_urdf(robot_element, origin)
    if tree.base_type != "fixed":
        raise UVMSError(f"{origin}: an arm to mount must have a fixed root, but its root joint is {tree.base_type}")
    warn_missing_meshes(robot_element, base_dir, None, origin)
    prefixed = prefix_names(robot_element, prefix)
    arm_model = build_model(prefixed, "fixed", tree, origin)
    clashes = sorted(set(vehicle.frame_names) & {f.name for f in arm_model.frames} - {"universe"})
    if clashes:
        raise UVMSError(f"names of the arm clash with the vehicle's: {', '.join(clashes[:5])}; pass another prefix=")
    if placement is None:
        placement = pin.SE3.Identity()
    elif not isinstance(placement, pin.SE3):
        values = np.asarray(placement, dtype=float)
        if values.shape != (6,) or not np.all(np.isfinite(values)):
            raise UVMSError("placement must be a pin.SE3 or 6 finite numbers [x, y, z, roll, pitch, yaw]")
        placement = pose_from_xyzrpy(values)
    model = pin.appendModel(vehicle.model, arm_model, vehicle.frame_id(parent_frame), placement)
    model.name = f"{vehicle.name}+{Path(origin).stem}"
    if ee is None:
        vehicle_ees = [name for name in vehicle.ee_frames if name == "ee" or name.endswith("_ee")]
        ee = vehicle_ees + default_end_effectors(arm_model)
    return Robot(model, ee=ee, name=model.name, source=f"{vehicle.source} + {origin}")


def arm_source(arm: str | os.PathLike) -> Path:
    """Path of an arm given as a file, a shipped model name or an example-robot-data name."""
    candidate = Path(arm)
    if candidate.is_file() or str(arm) in resources.shipped_models():
        return resources.resolve_model_path(arm)
    return resources.example_robot_urdf(str(arm))


def prefix_names(robot_element: ET.Element, prefix: str) -> str:
    """URDF text with ``prefix`` prepended to every link and joint name and reference.

    A joint that shares its name with a link gets a ``_joint`` suffix: Pinocchio
    would otherwise hold two frames of one name, which ``appendModel`` rejects.
    """
    for element in robot_element.iter():
        element.attrib.pop("_owner", None)  # annotations of uvms.checks
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
    for element in robot_element.iter("mimic"):
        element.set("joint", joint_names.get(element.get("joint"), element.get("joint")))
    return ET.tostring(robot_element, encoding="unicode")
