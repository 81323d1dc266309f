"""What HippoCampus's Gazebo plugins (``hippo_gz_plugins``) say about a vehicle: thruster, hydrodynamics, buoyancy.

Registered for HippoCampus in :mod:`uvms.dynamics.plugins.readers`; recognised by their ``name`` attribute
(``hippo_gz_plugins::thruster``, ``::hydrodynamics``, ``::buoyancy``: :mod:`uvms.model.plugins`). Read from
github.com/HippoCampusRobotics/hippo_simulation, ``hippo_gz_plugins/src/thruster/thruster_private.{hpp,cpp}``,
``src/hydrodynamics/hydrodynamics.cpp``, ``src/buoyancy/buoyancy_private.cpp`` (as ``hippo_sim``'s
``thruster_macro.xacro`` and ``bluerov_macro.xacro`` write them).

Thruster (:func:`read_hippo_thruster`)
-------------------------------------
``<link>`` is pushed along its own x axis (``link_.AddWorldForce(pose.Rot() * (force, 0, 0))``); ``<joint>`` is the
propeller joint it spins. A throttle in [-1, 1] (below 0.11 a dead band) sets the rotor speed
omega = throttle * turning_direction * ``<maximum_rpm>`` / 60 * 2 pi; at n = |omega| / 2 pi revolutions per second
the thrust is ``ThrusterForce``::

    T(n) = max(0, quadratic_coeff n^2 + linear_coeff n + constant_coeff),   force = sign(omega) propeller_direction T

so the thrust is symmetric: max_forward = max_reverse = the largest T over n in [0, maximum_rpm / 60]. The rotor
speed follows its set point through a first-order filter of ``<timeconstant_up>`` / ``<timeconstant_down>`` [s];
when both are equal and > 0 that is the time constant (as uuv_simulator's FirstOrder, a lag of the rotor), else the
plugin gives none (``thrusters.yaml`` or uvms's default completes it). ``<rpm_scaler>`` only scales the joint's
drawn spin and ``<torque_coeff>`` the reaction torque: neither changes the thrust.

Hydrodynamics (:func:`hippo_hydrodynamics_fields`)
-------------------------------------------------
Each ``<hydrodynamics>`` element: ``<link>``, ``<added_mass_linear>``, ``<added_mass_angular>``,
``<damping_linear>``, ``<damping_angular>`` (3 numbers each, positive, link frame; 0 when absent, as the plugin).
The plugin applies ``damping_force = -diag(damping_linear) v`` and ``-diag(damping_angular) w`` (it negates the
values it reads), so they are uvms's linear damping coefficients d_l as they are. The added masses are the diagonal
of M_A; uvms applies Fossen's complete added-mass model with them (M_A nu' in the mass matrix and -C_A nu), where the
plugin applies a Coriolis-like term only.

Buoyancy (:func:`hippo_buoyancy_fields`)
---------------------------------------
Each ``<buoyancy>`` element: ``<link_name>`` (default ``base_link``), ``<compensation>`` c (default 1),
``<origin>`` (the centre of buoyancy in the link frame) and ``<force_added>``. The plugin pushes up with
9.81 m c, m the link's mass as Gazebo sees it (its own and that of the links fixed-joint lumping merges into it),
so uvms's volume is V = c m / rho (rho g V with g = 9.81 m/s^2). ``<height_scale_limit>`` fades buoyancy at the
surface: uvms's vehicle is under water. A non-zero ``<force_added>`` (a constant force added to every world
component) is not modelled and refused.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np

from ...errors import ModelCheckError
from ..thrusters.sources import PluginThruster, _floats, _optional, joint_axis, thrust_limits


def read_hippo_thruster(plugin: ET.Element, root: ET.Element, name: str, where: str) -> PluginThruster:
    """What one ``hippo_gz_plugins::thruster`` says (the module docstring).

    Raises:
        ModelCheckError: no ``<link>``, a ``<joint>`` that is no joint carrying it, a value that is not a number,
            a thrust curve without positive thrust, a negative maximum_rpm.
    """
    link = (plugin.findtext("link") or "").strip()
    if not link:
        raise ModelCheckError(f"{where}: <link> is missing; it names the link the thrust acts on (along its x axis)")
    joint = (plugin.findtext("joint") or "").strip()
    if joint:
        joint_axis(root, joint, link, where)  # checks that the joint carries the link; the thrust is along x
    top = _optional(plugin, "maximum_rpm", 800.0, where) / 60.0  # [rev/s]; the plugin's 3.14 * 2 / 6.28 is 1
    if top < 0 or math.isinf(top):
        raise ModelCheckError(f"{where}: <maximum_rpm> must be a finite number >= 0, got {top * 60.0:g}")
    a, b, c = (_optional(plugin, f"{order}_coeff", 0.0, where) for order in ("quadratic", "linear", "constant"))
    speeds = [0.0, top] + ([-b / (2 * a)] if a != 0 and 0 < -b / (2 * a) < top else [])
    thrust = max(max(0.0, a * n * n + b * n + c) for n in speeds)
    given = thrust_limits(-thrust, thrust, where, "check <maximum_rpm> and the thrust coefficients")
    up = _optional(plugin, "timeconstant_up", 0.0, where)
    down = _optional(plugin, "timeconstant_down", 0.0, where)
    if up == down and up > 0 and math.isfinite(up):
        given["time_constant"] = up
    return PluginThruster(name, link, None, given)


def _vector(element: ET.Element, tag: str, where: str) -> np.ndarray:
    """3 numbers of a tag, zeros when it is absent (as the plugins' defaults)."""
    text = element.findtext(tag)
    if text is None:
        return np.zeros(3)
    values = _floats(text, tag, where)
    if values.shape != (3,):
        raise ModelCheckError(f"{where}: <{tag}> must be 3 numbers, got {text.strip()!r}")
    return values


def hippo_hydrodynamics_fields(element: ET.Element, where: str) -> dict[str, object]:
    """The fields of one ``<hydrodynamics>`` element (the module docstring), in uvms's conventions.

    Raises:
        ModelCheckError: a value that is not 3 numbers, a negative damping or added mass.
    """
    values = {tag: _vector(element, tag, where) for tag in
              ("added_mass_linear", "added_mass_angular", "damping_linear", "damping_angular")}
    for tag, vector in values.items():
        if np.any(vector < 0):
            raise ModelCheckError(f"{where}: <{tag}> must be >= 0 (the plugin takes positive coefficients and "
                                  f"negates the damping itself), got {vector.tolist()}")
    added = np.concatenate([values["added_mass_linear"], values["added_mass_angular"]])
    return {"added_mass": np.diag(added),
            "linear_damping": np.concatenate([values["damping_linear"], values["damping_angular"]])}


def hippo_buoyancy_fields(element: ET.Element, lumped_mass: float | None, density: float,
                          where: str) -> dict[str, object]:
    """The fields of one ``<buoyancy>`` element: ``volume`` [m^3] and ``center_of_buoyancy`` (the module docstring).

    Args:
        element: the ``<buoyancy>``; lumped_mass: the link's mass as Gazebo sees it [kg] (None: the model gives
            none); density: the fluid density [kg/m^3]; where: for messages.

    Raises:
        ModelCheckError: a non-zero force_added, a negative compensation, a link without mass.
    """
    compensation = _optional(element, "compensation", 1.0, where)
    if compensation < 0 or math.isinf(compensation):
        raise ModelCheckError(f"{where}: <compensation> must be a finite number >= 0, got {compensation:g}")
    if _optional(element, "force_added", 0.0, where) != 0:
        raise ModelCheckError(f"{where}: a non-zero <force_added> (a constant force on every world axis) is not "
                              f"modelled; give 0 and express the extra buoyancy by <compensation>")
    if lumped_mass is None:
        raise ModelCheckError(f"{where}: the plugin's buoyancy is the link's mass times <compensation>, and the "
                              f"link has no <inertial> mass")
    return {"volume": compensation * lumped_mass / density,
            "center_of_buoyancy": _vector(element, "origin", where)}
