"""Hydrodynamic parameters of the links of a UVMS: buoyancy, added mass, damping (Fossen's model).

Where they come from
====================
The model file, in the block that uuv_simulator's underwater-object plugin reads
(``libuuv_underwater_object_ros_plugin.so``), so a model written for one works in
the other::

    <gazebo>
      <plugin name="uuv_plugin" filename="libuuv_underwater_object_ros_plugin.so">
        <fluid_density>1028.0</fluid_density>
        <link name="base_link">
          <neutrally_buoyant>0</neutrally_buoyant>     <!-- 1: volume = link mass / density -->
          <volume>0.0134</volume>                      <!-- m^3 -->
          <center_of_buoyancy>0 0 0.01</center_of_buoyancy>  <!-- m, link frame -->
          <hydrodynamic_model>
            <type>fossen</type>                        <!-- or sphere, cylinder, spheroid, box -->
            <added_mass>36 numbers, row-major</added_mass>
            <linear_damping>6 numbers (or 36, diagonal)</linear_damping>
            <quadratic_damping>6 numbers (or 36, diagonal)</quadratic_damping>
          </hydrodynamic_model>
        </link>
      </plugin>
    </gazebo>

The shape models (``sphere``, ``cylinder``, ``spheroid``, ``box``) set added-mass and drag entries from
``<radius>``, ``<length>``, ``<width>``, ``<height>``, ``<axis>``, ``<cd>`` (or the link's ``<box>``) over those
of ``fossen``, as uuv_simulator does (:mod:`uvms.dynamics.hydro.shapes`). Volume, centre of buoyancy and
``neutrally_buoyant`` are read for every type.

Or a YAML file beside the model (``hydrodynamics.yaml``, same keys and the same conventions; see
:func:`~uvms.dynamics.hydro.uuv.load_hydrodynamics_yaml`, README.md "Hydrodynamics of your vehicle" and the complete
example ``models/example_hydrodynamics.yaml``).

Conventions of the file (those of uuv_simulator's ``HMFossen``)
--------------------------------------------------------------
* ``center_of_buoyancy`` is in the link frame (ROS, x forward, y left, z up).
* ``added_mass`` and the damping are in SNAME body axes (x forward, y starboard,
  z down: uuv_simulator converts the link velocity with ``ToNEDConvention``),
  order [u v w p q r], about the link frame origin.
* Damping values are Fossen's hydrodynamic derivatives, which are negative:
  ``linear_damping`` = [X_u, Y_v, Z_w, K_p, M_q, N_r] <= 0,
  ``quadratic_damping`` = [X_u|u|, ...] <= 0 and ``linear_damping_forward_speed``
  = [X_uu, ...] <= 0 (the linear damping that grows with the forward speed u); the plugin
  applies D(nu) = -diag(linear) - u diag(linear_damping_forward_speed) - diag(quadratic) |nu|
  (``HMFossen::ComputeDampingMatrix``: u the signed surge speed relative to the water). A
  positive value would feed energy into the motion and is refused.

The parameters themselves (:class:`LinkHydrodynamics`, :class:`HydroParameters`, in uvms's own FLU
conventions) live in :mod:`uvms.dynamics.hydro.parameters` and are importable from here.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING

from ...errors import ModelParseError, UVMSError
from ...robot.robot import check_robot
from ..plugins.readers import read_hydro_plugins
from .parameters import HydroParameters, LinkHydrodynamics
from .uuv import MODEL_KEYS, MODEL_TYPES, link_from_uuv, load_hydrodynamics_yaml, urdf_link_masses

__all__ = ["MODEL_KEYS", "MODEL_TYPES", "HydroParameters", "LinkHydrodynamics", "hydrodynamics_of",
           "link_from_uuv", "load_hydrodynamics_yaml", "parse_hydrodynamics", "urdf_link_masses"]

if TYPE_CHECKING:
    import pinocchio as pin

    from ...robot.robot import Robot

#: Name of the YAML file looked for beside a model.
YAML_NAME = "hydrodynamics.yaml"
def parse_hydrodynamics(
    urdf: str, origin: str = "<string>", link_names: Iterable[str] | None = None, moving: Iterable[str] = ()
) -> HydroParameters | None:
    """The hydrodynamic parameters written in a URDF's plugin blocks: uuv_simulator's underwater-object plugin,
    Gazebo Sim's Hydrodynamics and Buoyancy, HippoCampus's (:mod:`uvms.dynamics.plugins.readers`).

    Args:
        urdf: URDF text (xacro already expanded).
        origin: name of the model for messages.
        link_names: the model's links (None: not checked here); a block naming another link is skipped.
        moving: the joints that move in the model's file (``robot.joint_classes``; frozen since, they are fixed in
            ``urdf``): Gazebo lumps no link through them (:func:`~uvms.dynamics.plugins.readers.lumped_mass`).

    Returns:
        The parameters, or None when the URDF has no such plugin.

    Raises:
        ModelParseError: not well-formed XML.
        ModelCheckError: an invalid value, a link given twice, plugins with different densities.

    Warns:
        SkippedLinkWarning: a block naming a link the model does not have (skipped, as Gazebo does).
    """
    try:
        root = ET.fromstring(urdf)
    except ET.ParseError as exc:
        raise ModelParseError(f"{origin}: malformed XML ({exc})") from None
    return read_hydro_plugins(root, origin, link_names, moving)


# ------------------------------------------------------------- for a robot
def hydrodynamics_of(robot: Robot, path: str | os.PathLike | None = None, *, required: bool = True) -> HydroParameters:
    """The hydrodynamic parameters of a loaded Robot, checked against its links.

    Looked for in this order: ``path`` (a YAML file) when given; else the
    uuv_simulator block of the robot's URDF; else ``hydrodynamics.yaml`` in the
    folder of the model file. A model with both a block and that YAML is
    ambiguous and refused: pass ``path`` to choose.

    Args:
        robot: a :class:`uvms.Robot` (uses ``urdf``, ``source`` and its Pinocchio frames).
        path: a YAML file to use instead of what the model holds.
        required: when False, a model with no parameters gets empty ones (no
            hydrodynamics) instead of an error.

    Raises:
        UVMSError: no parameters (and ``required``), or both a block and a YAML file.
        NameNotFound: a link that the model does not have (the message lists close names).
        ModelCheckError, ModelParseError: invalid parameters.
    """
    check_robot(robot, "hydrodynamics_of")
    names = body_frame_names(robot.model)
    masses = urdf_link_masses(robot.urdf_root) if robot.urdf_root is not None else {}
    if path is not None:
        hydro = load_hydrodynamics_yaml(path, masses, names)
    else:
        from_urdf = parse_hydrodynamics(robot.urdf, robot.source, names, robot.joint_classes) if robot.urdf else None
        folder = Path(robot.source).parent if robot.source and not robot.source.startswith("<") else None
        beside = folder / YAML_NAME if folder is not None and (folder / YAML_NAME).is_file() else None
        if from_urdf is not None and beside is not None:
            raise UVMSError(
                f"{robot.source}: hydrodynamic parameters are both in the model's uuv_simulator block and in "
                f"{beside}; pass path= to choose the YAML, or remove one")
        hydro = from_urdf if from_urdf is not None else (
            load_hydrodynamics_yaml(beside, masses, names) if beside is not None else None)
    if hydro is None:
        if required:
            raise UVMSError(
                f"{robot.source}: the model has no hydrodynamic parameters; add a uuv_simulator underwater-object "
                f"plugin block to the URDF or a {YAML_NAME} beside it (see uvms.dynamics.hydro.hydrodynamics)")
        return HydroParameters(source=f"{robot.source} (no hydrodynamic parameters)")
    hydro.check_links(names)
    return hydro


def body_frame_names(model: pin.Model) -> list[str]:
    """Names of the link (BODY) frames of a Pinocchio model, in model order."""
    import pinocchio as pin

    return [frame.name for frame in model.frames if frame.type == pin.FrameType.BODY]
