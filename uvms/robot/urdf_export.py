"""The URDF a Robot saves: its model's text made self-describing, so ``uvms.load`` reads it back unchanged.

Two things a model's URDF text may leave to the loader are written out:

* the base: a vehicle joint that uvms added above a plain root link (``base="floating"/"planar"``, or the
  root-link rule of ``uvms.load``) becomes a ``floating``/``planar`` joint from a massless ``world`` link; a
  root link that carries mass but was held by ``base="fixed"`` gets a ``fixed`` joint from ``world``
  (a massless root is a fixed base by the same rule);
* mesh files given by a relative path become absolute paths (the saved file may live in another folder);
  ``package://`` and ``file://`` URIs are kept.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

#: URDF joint types of the vehicle joint, by base type.
BASE_JOINT_TYPES = ("floating", "planar")


def self_describing_urdf(urdf: str, base_type: str, vehicle_joint: str | None, source: str) -> str:
    """URDF text that states its base and its mesh files (see the module docstring).

    Args:
        urdf: the model's URDF text.
        base_type: "floating", "planar" or "fixed", the base of the model built from ``urdf``.
        vehicle_joint: name of the vehicle joint of the model (None for a fixed base).
        source: the model file, for relative mesh paths (``"<string>"`` or a composition: none are resolved).

    Returns:
        The URDF text.
    """
    robot = ET.fromstring(urdf)
    children = {child.get("link") for child in robot.iter("child")}
    links = {link.get("name"): link for link in robot.findall("link")}
    root = next(name for name in links if name not in children)
    root_joints = [j for j in robot.findall("joint") if j.find("parent") is not None
                   and j.find("parent").get("link") == root and j.get("type") in BASE_JOINT_TYPES]
    mass = links[root].find("inertial/mass")
    carries_mass = mass is not None and float(mass.get("value", "0")) > 0
    if base_type in BASE_JOINT_TYPES and not root_joints:
        add_root(robot, root, vehicle_joint or "base_joint", base_type, links)
    elif base_type == "fixed" and carries_mass:
        add_root(robot, root, unique(f"{root}_fixed", links, robot), "fixed", links)
    absolute_mesh_paths(robot, source)
    return ET.tostring(robot, encoding="unicode")


def unique(name: str, links: dict, robot: ET.Element) -> str:
    """``name``, or ``name_2``, ``name_3``... : not a link or joint name of the document."""
    taken = set(links) | {joint.get("name") for joint in robot.iter("joint")}
    candidate, count = name, 1
    while candidate in taken:
        count += 1
        candidate = f"{name}_{count}"
    return candidate


def add_root(robot: ET.Element, root: str, joint_name: str, joint_type: str, links: dict) -> None:
    """Put a massless ``world`` link above the root link, joined by a joint of ``joint_type``."""
    world = unique("world", links, robot)
    robot.insert(0, ET.Element("link", name=world))
    joint = ET.Element("joint", name=joint_name, type=joint_type)
    ET.SubElement(joint, "parent", link=world)
    ET.SubElement(joint, "child", link=root)
    if joint_type == "planar":
        ET.SubElement(joint, "axis", xyz="0 0 1")  # the x-y plane, as the joint uvms adds
    robot.insert(1, joint)


def absolute_mesh_paths(robot: ET.Element, source: str) -> None:
    """Make relative mesh paths absolute against the folder of ``source`` (when it is a file)."""
    folder = Path(source).parent if Path(source).is_file() else None
    if folder is None:
        return
    for mesh in robot.iter("mesh"):
        uri = mesh.get("filename", "")
        if uri and "://" not in uri and not Path(uri).is_absolute():
            mesh.set("filename", str((folder / uri).resolve()))
