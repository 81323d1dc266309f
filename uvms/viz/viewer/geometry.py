"""Geometry of the browser viewer: the URDF visuals with their mesh URIs resolved, or a stick skeleton.

The geometry comes from the model's URDF ``<visual>`` elements (mesh URIs resolved as
:func:`uvms.load` does: ``package://`` through the packages the robot was loaded with, ``robot.packages``
(:mod:`uvms.model.packages`); meshes that cannot be found are left out). A mesh is a stranger's file too: a
mesh that :func:`uvms.model.meshes.mesh_refusal` refuses (format, size, a compressed archive) is left out with a
warning that names it and the rule, checked before any loader opens it (:func:`uvms.model.meshes.resolved_urdf`).
A model without visual geometry is shown as a skeleton: a cylinder per arm link (parent joint origin ->
joint origin), a sphere per joint, and the end effectors in orange.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin

from ...errors import GeometryWarning, MissingMeshWarning
from ...model.meshes import missing_meshes_note, resolved_urdf
from ...robot.robot import Robot
from .collision import viewer_collision_model

SKELETON_COLOUR = np.array([0.35, 0.35, 0.4, 1.0])
EE_COLOUR = np.array([1.0, 0.5, 0.05, 1.0])


def _align_z(direction: np.ndarray) -> np.ndarray:
    """A rotation whose z axis is the unit vector ``direction``."""
    return pin.Quaternion.FromTwoVectors(np.array([0.0, 0.0, 1.0]), direction).toRotationMatrix()


def skeleton_geometry(robot: Robot, radius: float | None = None) -> pin.GeometryModel:
    """Stick geometry of any model: a cylinder per arm link, a sphere per joint, end effectors in orange.

    Args:
        robot: the robot.
        radius: link radius [m]; default 4 % of the longest link (at least 5 mm).
    """
    import coal  # shipped with the pin wheel

    model = robot.model
    links = [(j, model.jointPlacements[j].translation) for j in range(1, model.njoints) if model.parents[j] > 0]
    ee = [(robot.frame_id(name), name) for name in robot.ee_frames]
    lengths = [np.linalg.norm(d) for _, d in links] + [np.linalg.norm(model.frames[f].placement.translation)
                                                        for f, _ in ee]
    if radius is None:
        radius = max(0.04 * max(lengths, default=0.0), 0.005)
    geometry = pin.GeometryModel()

    def add(name: str, joint: int, placement: pin.SE3, shape, colour: np.ndarray) -> None:
        frame = model.getFrameId(model.names[joint], pin.FrameType.JOINT) if joint > 0 else 0
        item = pin.GeometryObject(name, joint, frame, placement, shape)
        item.meshColor = colour
        geometry.addGeometryObject(item)

    def segment(name: str, joint: int, start: np.ndarray, end: np.ndarray, colour: np.ndarray) -> None:
        offset = end - start
        length = float(np.linalg.norm(offset))
        if length > 1e-6:
            add(name, joint, pin.SE3(_align_z(offset / length), (start + end) / 2),
                coal.Cylinder(radius, length), colour)

    for joint in range(1, model.njoints):
        add(f"skeleton/joint_{model.names[joint]}", joint, pin.SE3.Identity(), coal.Sphere(1.6 * radius),
            SKELETON_COLOUR)
    for joint, offset in links:
        segment(f"skeleton/link_{model.names[joint]}", model.parents[joint], np.zeros(3), offset, SKELETON_COLOUR)
    for frame_id, name in ee:
        frame = model.frames[frame_id]
        placement = frame.placement
        segment(f"skeleton/ee_{name}", frame.parentJoint, np.zeros(3), placement.translation, EE_COLOUR)
        add(f"skeleton/ee_tip_{name}", frame.parentJoint, placement, coal.Sphere(1.8 * radius), EE_COLOUR)
    return geometry


def geometry_models(robot: Robot, skeleton: bool | None = None) -> tuple[pin.GeometryModel, pin.GeometryModel]:
    """The (visual, collision) geometry models the viewer shows.

    Args:
        robot: the robot.
        skeleton: add the stick geometry of :func:`skeleton_geometry`; None: only when the model
            has no visual geometry (no URDF, or a URDF without ``<visual>``).

    Returns:
        The visual model (URDF visuals, plus the skeleton) and the collision model (the shapes the collision
        objectives check, :func:`uvms.viz.viewer.collision.viewer_collision_model`; hidden by the viewer unless
        asked).

    Warns:
        MissingMeshWarning: some meshes cannot be found (they are left out).
        GeometryWarning: the collision geometry cannot be built (no collision shapes shown).
    """
    visual = visual_geometry(robot)
    collision = viewer_collision_model(robot) if robot.urdf is not None else pin.GeometryModel()
    if skeleton or (skeleton is None and visual.ngeoms == 0):
        for item in skeleton_geometry(robot).geometryObjects:
            visual.addGeometryObject(item)
    return visual, collision


def visual_geometry(robot: Robot) -> pin.GeometryModel:
    """The URDF's ``<visual>`` geometry (meshes as they are, their URIs resolved); empty without a URDF.

    Warns:
        MissingMeshWarning: some meshes cannot be found (they are left out).
        GeometryWarning: Pinocchio cannot read the geometry (an empty model).
    """
    if robot.urdf is None:
        return pin.GeometryModel()
    xml, missing = resolved_urdf(robot)
    if missing:
        source = Path(robot.source)
        folder = source.parent if source.is_file() else None
        warnings.warn(missing_meshes_note(robot.source, missing, folder, robot.packages,
                                          robot.source if folder else ""), MissingMeshWarning, stacklevel=3)
    try:
        return pin.buildGeomFromUrdfString(robot.model, xml, pin.GeometryType.VISUAL)
    except (RuntimeError, ValueError) as exc:
        warnings.warn(f"{robot.source}: Pinocchio cannot read the geometry ({' '.join(str(exc).split())}); "
                      f"it is not shown", GeometryWarning, stacklevel=3)
        return pin.GeometryModel()
