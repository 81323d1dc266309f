"""Which joints of a URDF carry a control surface (a fin), read from the simulator plugins that give it lift and drag.

Two plugins make a fin (:data:`FIN_PLUGINS`):

* uuv_simulator's fin plugin (``libuuv_fin_ros_plugin.so``, ``uuv_gazebo_plugins/src/FinPlugin.cc``): the fin is
  ``<joint_name>`` (the revolute joint the plugin turns to the commanded angle); ``<link_name>`` the link the lift
  and drag act on. A plugin without ``<joint_name>`` names its fin by the joint whose child is ``<link_name>``.
* Gazebo Sim's lift-drag system (``gz::sim::systems::LiftDrag``, ``gz-sim src/systems/lift_drag/LiftDrag.cc``): the
  fin is ``<control_joint_name>`` (its angle adds ``control_joint_rad_to_cl`` per radian to the lift coefficient),
  else the moving joint whose child is ``<link_name>`` (the link turns with it, which changes the angle of attack:
  the LRAUV's fins). A LiftDrag on a link no joint moves is a fixed lifting surface, not a control surface; one on
  a continuous joint is a rotor blade (Gazebo's propeller demo), not one either: a fin is a revolute joint.

Such a joint is class ``fin`` (made by :mod:`uvms.model.joint_classes` from :func:`control_surface_joints`): frozen
in the kinematics at 0 (or the limit nearest), its angle an actuator of the actuated plant
(:mod:`uvms.dynamics.thrusters.fins`), its written limits kept in its class.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Mapping

from .plugins import UUV, plugins_of

#: The plugins that make a fin, by kind: uuv_simulator's fin plugin and Gazebo Sim's LiftDrag system (recognised
#: by their entries of role ``fin`` in :data:`uvms.model.plugins.PLUGIN_KINDS`).
FIN_PLUGINS = ("uuv_fin", "gz_lift_drag")


def fin_plugins(robot: ET.Element) -> list[tuple[ET.Element, str]]:
    """The fin plugins of a URDF ``<robot>``, in the file's order, with their kinds (one of :data:`FIN_PLUGINS`)."""
    return [(plugin, "uuv_fin" if kind.simulator == UUV else "gz_lift_drag")
            for kind, plugin in plugins_of(robot, "fin")]


def text(plugin: ET.Element, tag: str) -> str:
    """The stripped text of ``<tag>`` in a plugin ("" when absent)."""
    return (plugin.findtext(tag) or "").strip()


def fin_joint(plugin: ET.Element, kind: str, moving: Mapping[str, ET.Element]) -> tuple[str | None, str]:
    """(the joint a fin plugin turns, or None for a fixed lifting surface; why, one line).

    Args:
        plugin, kind: the plugin and its kind (:func:`fin_plugin_kind`); moving: {name: joint} of the file's
            revolute, continuous and prismatic joints.
    """
    label = plugin.get("name", "")
    link = text(plugin, "link_name")
    by_child = {joint.find("child").get("link"): name for name, joint in moving.items()}
    named = text(plugin, "joint_name" if kind == "uuv_fin" else "control_joint_name")
    what = "uuv_simulator fin plugin" if kind == "uuv_fin" else "Gazebo Sim LiftDrag"
    if named:
        tag = "<joint_name>" if kind == "uuv_fin" else "<control_joint_name>"
        why = f"{what} {label!r} names it ({tag})"
    elif link in by_child:
        named, why = by_child[link], f"its link {link!r} is the <link_name> of {what} {label!r}"
    # a fin turns through an angle range: a continuous joint under a LiftDrag is a rotor blade (gz's propeller demo)
    if named in moving and moving[named].get("type") == "revolute":
        return named, why
    return None, ""


def control_surface_joints(robot: ET.Element, moving: Mapping[str, ET.Element]) -> dict[str, str]:
    """{joint: why it is a fin} of the fin plugins of a URDF (see the module docstring); the first plugin wins."""
    found: dict[str, str] = {}
    for plugin, kind in fin_plugins(robot):
        joint, why = fin_joint(plugin, kind, moving)
        if joint is not None:
            found.setdefault(joint, why)
    return found
