"""What Gazebo Sim's plugins say about a vehicle: the Thruster, Hydrodynamics and Buoyancy systems.

Registered for Gazebo Sim in :mod:`uvms.dynamics.plugins.readers`; recognised by :mod:`uvms.model.plugins`
(``gz-sim-thruster-system``, ``gz::sim::systems::Thruster``, their ``ignition-gazebo`` names, ...). Read from
gz-sim's sources (github.com/gazebosim/gz-sim, ``src/systems/thruster/Thruster.cc``,
``src/systems/hydrodynamics/Hydrodynamics.cc`` and ``HydrodynamicsUtils.hh``, ``src/systems/buoyancy/Buoyancy.hh``,
main branch of April 2026; the tags are those of gz-sim 7 and 8 too).

Thruster (:func:`read_gz_thruster`)
-----------------------------------
``<joint_name>`` (required) names the propeller joint; the plugin pushes its child link at the link's origin
(``Link::AddWorldWrench``) along the joint's axis (``jointWorldPose.Rot() * jointAxis``, the joint frame being the
child link's frame in a URDF): the thruster's frame is the child link, its direction the joint axis. The command is
a thrust [N] (default), or a propeller speed omega [rad/s] with ``<use_angvel_cmd>`` true, clamped to
[``<min_thrust_cmd>``, ``<max_thrust_cmd>``]; a speed gives the thrust of Fossen's propeller law
(``AngularVelToThrust``)::

    thrust = thrust_coefficient * fluid_density * propeller_diameter^4 * |omega| * omega

(defaults 1, 1000 kg/m^3, 0.02 m). The limits uvms takes are that clamp: in newtons, or through that law at the
ends of the speed range. A side the plugin leaves at its internal default (+-1000) is no limit the plugin gives:
``thrusters.yaml`` or uvms's default completes it (:func:`uvms.dynamics.thrusters.thrusters.complete_plugin_thrusters`),
as it does the time constant, which gz's Thruster does not have (its thrust follows the command at once).
``<velocity_control>``, ``<topic>``, ``<namespace>``, ``<deadband>``, the PID gains and the battery tags change how
gz spins the propeller or listens, not the thrust uvms models; the boolean tags are checked. gz's Thruster has no
``<max_velocity>``/``<min_velocity>`` tag: the speed range is ``<min/max_thrust_cmd>`` in ``use_angvel_cmd`` mode.

Hydrodynamics (:func:`gz_hydrodynamics_blocks`)
----------------------------------------------
One plugin per link (``<link_name>``). Its tags are Fossen's derivatives in the *link frame* (gz takes the link's
velocity relative to the current, ``pose.Rot().Inverse() * (v - current)``; the SNAME letters name the axes only,
no NED turn): added mass ``<xDotU>`` ... ``<nDotR>`` (all 36 ``<{x..n}Dot{U..R}>``, negative), linear damping
``<xU>`` ... ``<nR>`` and quadratic ``<xUabsU>`` ... ``<nRabsR>`` (negative). The force gz applies is
(``-kTotalWrench``)::

    f = Ma nu_r'  +  (L + Q_abs |nu_r|) nu_r  (+ its Coriolis term)      Ma = [<xDotU> ...], L = [<xU> ...]

so uvms's M_A = -Ma (made symmetric, :func:`~uvms.dynamics.hydro.parameters.symmetrized_added_mass`), d_l = -L and
d_q = -Q_abs on the diagonal: the same values negated, as from uuv_simulator's file, without its FRD turn. uvms
damps with diagonal matrices: an off-diagonal damping tag, or a signed quadratic ``<xUU>`` (which gz warns may be
unstable), is refused. The Coriolis term uvms applies is Fossen's -C_A(nu_r) nu_r (eq. 6.43) of the full M_A, its
one added-mass model (exact in the mass matrix); gz's explicit C matrix uses the diagonal of Ma only (and differs
between gz-sim versions). ``<default_current>`` is the ocean current (world frame); ``<disable_added_mass>`` true
drops the added mass; ``<disable_coriolis>`` cannot keep M_A without its C_A in uvms and is stated by a
:class:`~uvms.errors.PluginSettingWarning`, as is a current table (``<lookup_current_*>``).

Buoyancy (:func:`gz_buoyancy_density`)
-------------------------------------
A world system usually; when the URDF holds one, ``<uniform_fluid_density>`` (or ``<graded_buoyancy>``'s
``<default_density>``, the water, with a warning that the layers are not modelled) is the fluid density. gz
computes each link's volume from its collision shapes; uvms takes volumes from the hydrodynamic data only.
"""

from __future__ import annotations

import math
import warnings
import xml.etree.ElementTree as ET

import numpy as np

from ...errors import ModelCheckError, PluginSettingWarning
from ..hydro.parameters import symmetrized_added_mass
from ..thrusters.sources import PluginThruster, _float, _floats, _optional, joint_axis, thrust_limits

#: SNAME letters: force/moment axes and velocities, in the order [u v w p q r].
AXES, VELOCITIES = "xyzkmn", "UVWPQR"


def plugin_flag(plugin: ET.Element, tag: str, default: bool, where: str) -> bool:
    """A boolean tag as sdformat reads it (``true``/``1``/``false``/``0``, any case); ``default`` when absent.

    Raises:
        ModelCheckError: any other text.
    """
    text = plugin.findtext(tag)
    if text is None:
        return default
    value = text.strip().lower()
    if value not in ("true", "1", "false", "0"):
        raise ModelCheckError(f"{where}: <{tag}> must be true or false (or 1/0), got {text!r}")
    return value in ("true", "1")


# ------------------------------------------------------------------ Thruster
def read_gz_thruster(plugin: ET.Element, root: ET.Element, name: str, where: str) -> PluginThruster:
    """What one ``gz::sim::systems::Thruster`` says (the module docstring).

    Args:
        plugin: the ``<plugin>``; root: the URDF ``<robot>``; name: the thruster's name; where: for messages.

    Raises:
        ModelCheckError: no ``<joint_name>`` or no such joint, a zero axis, a value that is not a number or a
            boolean, ``max_thrust_cmd`` < ``min_thrust_cmd``, a range without positive thrust.
    """
    joint_name = (plugin.findtext("joint_name") or "").strip()
    if not joint_name:
        raise ModelCheckError(f"{where}: <joint_name> is missing; it names the propeller joint the thrust acts "
                              f"along (gz leaves such a plugin uninitialised)")
    joint = next((j for j in root.findall("joint") if j.get("name") == joint_name), None)
    child = joint.find("child") if joint is not None else None
    link = child.get("link", "") if child is not None else ""
    direction = joint_axis(root, joint_name, link, where)  # also names an unknown joint with the close names
    plugin_flag(plugin, "velocity_control", False, where)  # checked: it changes how gz spins the propeller only
    speed_command = plugin_flag(plugin, "use_angvel_cmd", False, where)
    high = _optional(plugin, "max_thrust_cmd", math.inf, where)
    low = _optional(plugin, "min_thrust_cmd", -math.inf, where)
    if high < low:
        raise ModelCheckError(f"{where}: <max_thrust_cmd> ({high:g}) must be >= <min_thrust_cmd> ({low:g})")
    check = "check <max_thrust_cmd> and <min_thrust_cmd>"
    if speed_command:
        if plugin.find("thrust_coefficient") is None:  # gz then updates it from alpha_1, alpha_2 and the speed
            low, high = -math.inf, math.inf
        else:
            low, high = sorted(gz_thrust(plugin, omega, where) for omega in (low, high))
        check += " (propeller speeds [rad/s]) and the thrust coefficient"
    return PluginThruster(name, link, direction, thrust_limits(low, high, where, check))


def gz_thrust(plugin: ET.Element, omega: float, where: str) -> float:
    """The thrust [N] of gz's Thruster at a propeller speed omega [rad/s] (``AngularVelToThrust``), +-inf at
    omega = +-inf: thrust_coefficient * fluid_density * propeller_diameter^4 * |omega| * omega."""
    scale = (_optional(plugin, "thrust_coefficient", 1.0, where) * _optional(plugin, "fluid_density", 1000.0, where)
             * _optional(plugin, "propeller_diameter", 0.02, where) ** 4)
    if math.isinf(omega):
        return 0.0 if scale == 0 else math.copysign(math.inf, scale * omega)
    return scale * abs(omega) * omega


# ------------------------------------------------------------------ Hydrodynamics
def gz_hydrodynamics_fields(plugin: ET.Element, where: str) -> dict[str, object]:
    """The hydrodynamic fields of one ``gz::sim::systems::Hydrodynamics`` (the module docstring), in uvms's
    conventions: ``added_mass`` (6, 6), ``linear_damping`` and ``quadratic_damping`` (6,) >= 0, and ``current``
    (3,) [m/s] world frame when ``<default_current>`` is given.

    Raises:
        ModelCheckError: a value that is not a number, an off-diagonal or signed-quadratic damping term, a positive
            damping derivative, an added mass that is not symmetric positive semi-definite.
    """
    def tag(name: str) -> float:
        return _optional(plugin, name, 0.0, where)

    added = -np.array([[tag(f"{a}Dot{v}") for v in VELOCITIES] for a in AXES]) + 0.0
    linear = np.array([[tag(f"{a}{v}") for v in VELOCITIES] for a in AXES])
    quadratic = np.zeros(6)
    for i, axis in enumerate(AXES):
        for j, velocity in enumerate(VELOCITIES):
            for k, other in enumerate(VELOCITIES):
                signed = f"{axis}{velocity}{other}"
                if tag(signed) != 0:
                    raise ModelCheckError(f"{where}: <{signed}> (a signed quadratic term) is not supported: uvms's "
                                          f"quadratic damping is |v| v on the diagonal (<xUabsU> ... <nRabsR>)")
                absolute = tag(f"{axis}{velocity}abs{other}")
                if i == j == k:
                    quadratic[i] = absolute
                elif absolute != 0:
                    raise ModelCheckError(f"{where}: <{axis}{velocity}abs{other}> is off the diagonal; uvms's "
                                          f"quadratic damping is diagonal (<xUabsU> ... <nRabsR>)")
    off = np.argwhere(linear - np.diag(np.diag(linear)) != 0)
    if off.size:
        i, j = off[0]
        raise ModelCheckError(f"{where}: <{AXES[i]}{VELOCITIES[j]}> is off the diagonal; uvms's linear damping is "
                              f"diagonal (<xU> ... <nR>)")
    for what, values in (("linear (<xU> ... <nR>)", np.diag(linear)), ("quadratic (<xUabsU> ...)", quadratic)):
        if np.any(values > 0):
            raise ModelCheckError(f"{where}: the {what} damping derivatives {values.tolist()} hold positive values: "
                                  f"Gazebo's are Fossen's derivatives (<= 0) and a positive one would add energy; "
                                  f"negate them")
    if plugin_flag(plugin, "disable_added_mass", False, where):
        added = np.zeros((6, 6))
    elif plugin_flag(plugin, "disable_coriolis", False, where) and np.any(added != 0):
        warnings.warn(f"{where}: <disable_coriolis> is not followed: uvms applies the added mass with its Coriolis "
                      f"term C_A (Fossen eq. 6.43), which keeps the energy balance", PluginSettingWarning,
                      stacklevel=4)
    if any(plugin.find(f"lookup_current_{axis}") is not None for axis in "xyz"):
        warnings.warn(f"{where}: the current table (<lookup_current_*>) is not read; uvms takes the constant "
                      f"<default_current> (or the scenario's current)", PluginSettingWarning, stacklevel=4)
    fields: dict[str, object] = {"added_mass": symmetrized_added_mass(added, where),
                                 "linear_damping": -np.diag(linear) + 0.0, "quadratic_damping": -quadratic + 0.0}
    if plugin.find("default_current") is not None:
        current = _floats(plugin.findtext("default_current"), "default_current", where)
        if current.shape != (3,):
            raise ModelCheckError(f"{where}: <default_current> must be 3 numbers [m/s], got {current.tolist()}")
        fields["current"] = current
    return fields


# ------------------------------------------------------------------ Buoyancy
def gz_buoyancy_density(plugin: ET.Element, where: str) -> float | None:
    """The fluid density [kg/m^3] of a ``gz::sim::systems::Buoyancy`` (the module docstring), or None.

    Raises:
        ModelCheckError: a density that is not a number > 0.
    """
    graded = plugin.find("graded_buoyancy")
    if graded is not None:
        text, tag = graded.findtext("default_density"), "graded_buoyancy/default_density"
        if graded.find("density_change") is not None:
            warnings.warn(f"{where}: the layers of <graded_buoyancy> are not modelled; uvms takes the fluid of "
                          f"<default_density> everywhere (a vehicle under water)", PluginSettingWarning, stacklevel=4)
    else:
        text, tag = plugin.findtext("uniform_fluid_density"), "uniform_fluid_density"
    if text is None:
        return None
    density = _float(text, tag, where)
    if not density > 0 or math.isinf(density):
        raise ModelCheckError(f"{where}: <{tag}> must be a density > 0 kg/m^3, got {text.strip()!r}")
    return density
