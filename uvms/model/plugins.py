"""Which simulator plugins of a URDF's ``<gazebo>`` blocks describe the vehicle: the registry of plugin kinds.

A model written for a simulator carries its thrusters and hydrodynamics as that simulator's plugins. Each kind uvms
reads is one :class:`PluginKind` of :data:`PLUGIN_KINDS`: the simulator, the role (``thruster``,
``hydrodynamics``, ``buoyancy``), how a ``<plugin>`` element is recognised (its ``filename`` or its ``name``) and,
for a thruster, the tags naming its propeller joint and link. The loader uses it to class propeller joints
(:mod:`uvms.model.joint_classes`); the readers of each kind, one module per simulator, are registered by simulator
in :mod:`uvms.dynamics.plugins.readers`.

======================  =============  ===========================================================================
simulator               role           recognised by
======================  =============  ===========================================================================
uuv_simulator           thruster       filename ``libuuv_thruster_ros_plugin.so`` (``<jointName>``, ``<linkName>``)
uuv_simulator           hydrodynamics  filename ``libuuv_underwater_object_ros_plugin.so``
Gazebo Sim              thruster       filename ``gz-sim-thruster-system`` (also ``libgz-sim8-...so``,
                                       ``ignition-gazebo-thruster-system``) or name ``gz::sim::systems::Thruster``
                                       (``ignition::gazebo::systems::Thruster``); ``<joint_name>``
Gazebo Sim              hydrodynamics  ``gz-sim-hydrodynamics-system`` / ``gz::sim::systems::Hydrodynamics``
Gazebo Sim              buoyancy       ``gz-sim-buoyancy-system`` / ``gz::sim::systems::Buoyancy``
HippoCampus             thruster       name ``hippo_gz_plugins::thruster`` (``<joint>``, ``<link>``)
HippoCampus             hydrodynamics  name ``hippo_gz_plugins::hydrodynamics``
HippoCampus             buoyancy       name ``hippo_gz_plugins::buoyancy``
======================  =============  ===========================================================================
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass

#: The simulators, as messages and ``uvms info`` name them.
UUV, GZ, HIPPO = "uuv_simulator", "Gazebo Sim", "HippoCampus"


@dataclass(frozen=True)
class PluginKind:
    """One kind of simulator plugin uvms reads.

    Attributes:
        simulator: :data:`UUV`, :data:`GZ` or :data:`HIPPO`; role: ``thruster``, ``hydrodynamics``, ``buoyancy``
            or ``fin`` (a control surface, :mod:`uvms.model.control_surfaces`).
        filename: a regular expression searched in the plugin's ``filename`` (None: not recognised by it).
        names: ``name`` attributes that recognise it (the class names the simulator registers).
        joint_tag, link_tag: the tags of a thruster plugin naming its propeller joint and link (None: it has none).
    """

    simulator: str
    role: str
    filename: str | None
    names: tuple[str, ...] = ()
    joint_tag: str | None = None
    link_tag: str | None = None

    def matches(self, plugin: ET.Element) -> bool:
        """Whether a ``<plugin>`` element is of this kind."""
        if self.filename is not None and re.search(self.filename, plugin.get("filename", "")):
            return True
        return plugin.get("name", "") in self.names

    def label(self, plugin: ET.Element, index: int) -> str:
        """The name of a thruster plugin: uuv_simulator's ``name``; Gazebo Sim's ``<joint_name>`` (its ``name`` is
        the class, the same for all); HippoCampus's ``thruster_<thruster_number>``, as its topics; else by index."""
        if self.simulator == GZ:
            return (plugin.findtext(self.joint_tag or "") or "").strip() or f"thruster_{index}"
        if self.simulator == HIPPO:
            return f"thruster_{(plugin.findtext('thruster_number') or str(index)).strip()}"
        return plugin.get("name") or f"thruster_{index}"


def _gz(system: str, cls: str) -> PluginKind:
    """A Gazebo Sim system: ``[lib]gz-sim[N]-<system>-system[.so]`` or ``[lib]ignition-gazebo[N]-...``."""
    return PluginKind(GZ, system, rf"(gz-sim|ignition-gazebo)\d*-{system}-system",
                      (f"gz::sim::systems::{cls}", f"ignition::gazebo::systems::{cls}"),
                      joint_tag="joint_name" if system == "thruster" else None)


#: Every plugin kind uvms reads, in the order their readers run.
PLUGIN_KINDS: tuple[PluginKind, ...] = (
    PluginKind(UUV, "thruster", r"uuv_thruster", joint_tag="jointName", link_tag="linkName"),
    PluginKind(UUV, "hydrodynamics", r"underwater_object"),
    _gz("thruster", "Thruster"),
    PluginKind(GZ, "hydrodynamics", r"(gz-sim|ignition-gazebo)\d*-hydrodynamics-system",
               ("gz::sim::systems::Hydrodynamics", "ignition::gazebo::systems::Hydrodynamics")),
    PluginKind(GZ, "buoyancy", r"(gz-sim|ignition-gazebo)\d*-buoyancy-system",
               ("gz::sim::systems::Buoyancy", "ignition::gazebo::systems::Buoyancy")),
    PluginKind(UUV, "fin", r"uuv_fin", joint_tag="joint_name", link_tag="link_name"),
    PluginKind(GZ, "fin", r"((gz-sim|ignition-gazebo)\d*-lift-drag-system|LiftDrag)",
               ("gz::sim::systems::LiftDrag", "ignition::gazebo::systems::LiftDrag"),
               joint_tag="control_joint_name", link_tag="link_name"),
    PluginKind(HIPPO, "thruster", None, ("hippo_gz_plugins::thruster",), joint_tag="joint", link_tag="link"),
    PluginKind(HIPPO, "hydrodynamics", None, ("hippo_gz_plugins::hydrodynamics",)),
    PluginKind(HIPPO, "buoyancy", None, ("hippo_gz_plugins::buoyancy",)),
)


def kind_of(plugin: ET.Element) -> PluginKind | None:
    """The kind of a ``<plugin>`` element, or None when uvms does not read it."""
    return next((kind for kind in PLUGIN_KINDS if kind.matches(plugin)), None)


def plugins_of(root: ET.Element, role: str) -> list[tuple[PluginKind, ET.Element]]:
    """The plugins of a role in a URDF ``<robot>``'s top-level ``<gazebo>`` blocks, in file order, with their kind."""
    found = []
    for plugin in (p for gazebo in root.findall("gazebo") for p in gazebo.findall("plugin")):
        kind = kind_of(plugin)
        if kind is not None and kind.role == role:
            found.append((kind, plugin))
    return found


def simulators(root: ET.Element, role: str) -> list[str]:
    """The simulators whose plugins of ``role`` the model has, in order of first appearance."""
    return list(dict.fromkeys(kind.simulator for kind, _ in plugins_of(root, role)))
