"""Which joints of a URDF carry a thruster's propeller (class ``propeller`` of :mod:`uvms.model.joint_classes`).

In the order the rules are tried, a moving joint is a propeller joint when

1. a thruster plugin names it or its child link (:data:`uvms.model.plugins.PLUGIN_KINDS`: uuv_simulator's
   ``<jointName>``/``<linkName>``, Gazebo Sim's ``<joint_name>``, HippoCampus's ``<joint>``/``<link>``);
2. the ``thrusters.yaml`` beside the model names its child link as a thruster's ``frame`` or ``parent``;
3. with neither, by its structure: a ``continuous`` joint to a leaf link (no joint below it) that is named like a
   propeller (a word of the link's or the joint's name is one of :data:`PROPELLER_WORDS`, digits aside:
   ``thruster1``, ``front_thruster_propeller_link``) and massless or tiny (at most :data:`PROPELLER_MASS_FRACTION`
   of the model's mass). The RDML ``blue`` BlueROV2 Heavy at its default args has exactly these: 8
   ``thruster<i>_joint`` continuous to ``thruster<i>`` links of 0.002 kg on a 13 kg vehicle, and no plugin.
   A spinning joint with such a name and no mass is no arm joint anybody commands; an arm's continuous wrist
   carries the rest of the arm (not a leaf) or a tool that is not named so.
"""

from __future__ import annotations

import re
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from pathlib import Path

from ..errors import ThrusterFileWarning, UVMSError
from .plugins import plugins_of
from .resources import read_yaml

#: The thruster file beside a model (read by uvms.dynamics.thrusters.thrusters).
THRUSTERS_YAML = "thrusters.yaml"
#: Words (digits stripped) of a link or joint name that name a propeller.
PROPELLER_WORDS = frozenset({"thruster", "propeller", "prop"})
#: A propeller link's mass is at most this fraction of the model's total mass (blue's: 0.002 kg of 13.016 kg).
PROPELLER_MASS_FRACTION = 0.01


def propeller_word(name: str) -> str | None:
    """The word of :data:`PROPELLER_WORDS` in a link or joint name ("thruster1" -> "thruster"), or None."""
    for word in re.split(r"[/_\-.]+", name.lower()):
        if word.rstrip("0123456789") in PROPELLER_WORDS:
            return word.rstrip("0123456789")
    return None


def propeller_joints(robot: ET.Element, moving: Mapping[str, ET.Element], model_dir: Path | None,
                     masses: Mapping[str, float]) -> dict[str, str]:
    """{joint: why it carries a propeller} by the rules of the module docstring.

    Args:
        robot: the URDF ``<robot>``; moving: {name: joint element} of its moving joints; model_dir: the model's
            folder (None: a string, no ``thrusters.yaml``); masses: {link: mass of its subtree [kg]}.

    Warns:
        ThrusterFileWarning: a ``thrusters.yaml`` beside the model that cannot be read (its other contents are
            checked by :mod:`uvms.dynamics.thrusters.thrusters` when thrusters are used).
    """
    by_child = {joint.find("child").get("link"): name for name, joint in moving.items()}
    found: dict[str, str] = {}
    for index, (kind, plugin) in enumerate(plugins_of(robot, "thruster")):
        label = kind.label(plugin, index)
        joint = (plugin.findtext(kind.joint_tag) or "").strip() if kind.joint_tag else ""
        link = (plugin.findtext(kind.link_tag) or "").strip() if kind.link_tag else ""
        if joint in moving:
            found.setdefault(joint, f"{kind.simulator} thruster plugin {label!r} names it (<{kind.joint_tag}>)")
        elif link in by_child:
            found.setdefault(by_child[link], f"its link {link!r} is the <{kind.link_tag}> of {kind.simulator} "
                                             f"thruster plugin {label!r}")
    for joint, why in _named_in_yaml(model_dir, by_child).items():
        found.setdefault(joint, why)
    parents = {joint.find("parent").get("link") for joint in robot.findall("joint")}
    total = masses.get(_root_link(robot), 0.0)
    for name, joint in moving.items():
        child = joint.find("child").get("link")
        if name in found or joint.get("type") != "continuous" or child in parents:
            continue
        word = propeller_word(child) or propeller_word(name)
        if word is not None and masses[child] <= PROPELLER_MASS_FRACTION * total:
            found[name] = (f"continuous joint to the leaf link {child!r} named like a propeller ({word}), "
                           f"{masses[child]:g} kg (at most {PROPELLER_MASS_FRACTION:.0%} of the model's "
                           f"{total:g} kg); no thruster plugin names it")
    return found


def _named_in_yaml(model_dir: Path | None, by_child: Mapping[str, str]) -> dict[str, str]:
    """{joint: why} for the links the ``thrusters.yaml`` beside the model names as a thruster's frame or parent."""
    path = model_dir / THRUSTERS_YAML if model_dir is not None else None
    if path is None or not path.is_file():
        return {}
    try:
        document = read_yaml(path, "thrusters")
    except UVMSError as exc:
        warnings.warn(f"{exc}; the propellers it names are not known, their joints are classed by the other "
                      f"rules", ThrusterFileWarning, stacklevel=5)
        return {}
    found: dict[str, str] = {}
    entries = document.get("thrusters") if isinstance(document, Mapping) else None
    for thruster, entry in (entries.items() if isinstance(entries, Mapping) else ()):
        for key in ("frame", "parent"):
            link = entry.get(key) if isinstance(entry, Mapping) else None
            if isinstance(link, str) and link in by_child:
                found.setdefault(by_child[link], f"its link {link!r} is the {key} of thruster {thruster!r} "
                                                 f"in {THRUSTERS_YAML}")
    return found


def _root_link(robot: ET.Element) -> str:
    """The link no joint has as its child (the checked URDF has one tree)."""
    children = {joint.find("child").get("link") for joint in robot.findall("joint")}
    return next((link.get("name", "") for link in robot.findall("link") if link.get("name") not in children), "")
