"""The tf tree of a robot as a ROS 2 bag gives it (REP-103/105): ``odom`` -> the vehicle's root link, every other
link under its URDF parent link, end-effector frames that are not links under their nearest link
(:mod:`uvms.scenario.bags.writer` writes it)."""

from __future__ import annotations

from dataclasses import dataclass

import pinocchio as pin

from ...errors import BagExportError
from ...robot.robot import Robot

#: The world frame of a bag (REP-105): the model's world, ENU, z up.
WORLD_FRAME = "odom"


@dataclass(frozen=True)
class TransformEdge:
    """One transform of the tf tree: ``parent`` -> ``child`` (frame names); ids are Pinocchio frame ids.

    ``parent_id`` is None for the world frame (``odom``); ``static`` when no joint moves between the two.
    """

    parent: str
    child: str
    parent_id: int | None
    child_id: int
    static: bool


def vehicle_root_link(robot: Robot) -> int | None:
    """Frame id of the vehicle's root link (the first link moved by the vehicle joint), None for a fixed base."""
    if robot.base_type == "fixed":
        return None
    return next((index for index, frame in enumerate(robot.model.frames)
                 if frame.type == pin.FrameType.BODY and frame.parentJoint == 1), None)


def _nearest_link(model: pin.Model, index: int) -> int | None:
    """The nearest link (BODY frame) above frame ``index``; None when the chain reaches the world."""
    while index != 0:
        index = model.frames[index].parentFrame
        if model.frames[index].type == pin.FrameType.BODY:
            return index
    return None


def frame_tree(robot: Robot) -> tuple[list[TransformEdge], dict[str, str]]:
    """The tf tree of a robot (module docstring) and the end-effector frames left out, with the reason.

    Raises:
        BagExportError: a link of the model is called ``odom`` (the world frame of the bag).
    """
    model, root = robot.model, vehicle_root_link(robot)
    links = [index for index, frame in enumerate(model.frames) if frame.type == pin.FrameType.BODY]
    link_names = {model.frames[index].name for index in links}
    if WORLD_FRAME in link_names:
        raise BagExportError(f"{robot.name}: a link is called {WORLD_FRAME!r}, the world frame of a bag (REP-105); "
                             f"rename the link")
    skipped = {}
    children = list(links)
    for name, index in zip(robot.ee_frames, robot.ee_frame_ids):
        if model.frames[index].type == pin.FrameType.BODY:
            continue
        if name in link_names:
            skipped[f"tf frame {name}"] = "the end effector is not a link and a link has its name"
        else:
            children.append(index)
    edges = []
    for child in children:
        parent = None if child == root else _nearest_link(model, child)
        parent_joint = 0 if parent is None else model.frames[parent].parentJoint
        edges.append(TransformEdge(
            parent=WORLD_FRAME if parent is None else model.frames[parent].name, child=model.frames[child].name,
            parent_id=parent, child_id=child, static=model.frames[child].parentJoint == parent_joint))
    return edges, skipped
