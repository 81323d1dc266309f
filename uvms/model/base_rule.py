"""The base rule of ``uvms.load``: which vehicle base a model gets, and why (one line for ``uvms info``).

* a ``floating``/``planar`` joint at the root link is the vehicle, as written;
* a plain root link that carries mass (an ``<inertial>`` with mass > 0) is a vehicle: a free-flying
  joint ``ADDED_BASE_JOINT`` is added above it;
* so is a massless root link whose rigid body (it and the links fixed to it) carries mass and propellers
  (:func:`rigid_body`): a vehicle written below a ``base_footprint``, as ROS 2 packages write them (RDML's
  ``blue``); an arm's massless ``world`` link carries a massive base but no propeller;
* a massless plain root link (``world``, an arm's mounting link) is a fixed base;
* ``base=`` overrides the last two ("fixed" holds a massive root link in the world), and may not
  contradict a root joint written in the file.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Mapping

from ..errors import BaseMismatchError, UVMSError
from ..robot.structure import JointClass
from . import checks

BASE_CHOICES = ("floating", "planar", "fixed")
#: Name given to a vehicle joint that uvms adds (base="floating"/"planar" on a plain root link).
ADDED_BASE_JOINT = "base_joint"


def rigid_body(robot: ET.Element, root: str, classes: Mapping[str, JointClass]) -> tuple[float, int]:
    """(mass [kg], propeller joints) of the root link's rigid body: the root and the links fixed to it (through
    fixed joints, recursively), and the joints of class ``propeller`` hanging from them."""
    children: dict[str, list[ET.Element]] = {}
    for joint in robot.findall("joint"):
        children.setdefault(joint.find("parent").get("link"), []).append(joint)
    masses = {link.get("name"): float(link.find("inertial/mass").get("value", "0"))
              for link in robot.findall("link") if link.find("inertial/mass") is not None}
    mass, propellers, stack = 0.0, 0, [root]
    while stack:  # a tree (checked): each link once
        link = stack.pop()
        mass += masses.get(link, 0.0)
        for joint in children.get(link, []):
            if joint.get("type") == "fixed":
                stack.append(joint.find("child").get("link"))
            elif getattr(classes.get(joint.get("name")), "kind", None) == "propeller":
                propellers += 1
    return mass, propellers


def decide_base(requested: str | None, tree: checks.TreeSummary, origin: str,
                body: tuple[float, int] = (0.0, 0)) -> tuple[str, str]:
    """The base type to build and why, by the rule of :func:`load`; ``body``: :func:`rigid_body` of the root.

    Returns:
        (base type, reason): the reason is one line for ``uvms info``, e.g. "floating (added: the root
        link 'hull' carries 1810 kg; base='fixed' to hold it)".

    Raises:
        UVMSError: an unknown base name.
        BaseMismatchError: a base that contradicts the file's root joint.
    """
    if requested is not None and requested not in BASE_CHOICES:
        raise UVMSError(f"unknown base {requested!r}; valid: {', '.join(BASE_CHOICES)} or None (the rule of "
                        "uvms.load: the file's root joint, else floating when the root link carries mass)")
    root, mass = tree.root_link, tree.root_mass
    if tree.base_type != "fixed":
        if requested is not None and requested != tree.base_type:
            raise BaseMismatchError(
                f"{origin}: base={requested!r} contradicts the file, whose root joint {tree.base_joint!r} is "
                f"{tree.base_type}; use base={tree.base_type!r} or None, or edit the model"
            )
        return tree.base_type, f"{tree.base_type} (the file's root joint {tree.base_joint!r})"
    carried = f"the root link {root!r} carries {mass:.4g} kg" if mass > 0 else f"the root link {root!r} has no mass"
    if mass <= 0 and body[0] > 0 and body[1] > 0:
        mass, carried = body[0], (f"the root link {root!r} and the links fixed to it carry {body[0]:.4g} kg and "
                                  f"{body[1]} propeller joint(s)")
    if requested is None:
        if mass > 0:
            return "floating", f"floating (added: {carried}; base='fixed' to hold it)"
        return "fixed", f"fixed ({carried}; base='floating' or 'planar' to make it a vehicle)"
    if requested == "fixed":
        return "fixed", f"fixed (base='fixed'; {carried})"
    return requested, f"{requested} (added by base={requested!r} above the root link {root!r})"
