"""``uvms info``: a model named on the command line (``--arg NAME=VALUE``) and the text that describes it."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from ..errors import UVMSError
from ..model.loader import load
from ..robot.robot import Robot
from .terminal import say


def parse_assignments(items: Sequence[str] | None) -> dict[str, str]:
    """``["NAME=VALUE", ...]`` -> {NAME: VALUE}."""
    assignments: dict[str, str] = {}
    for item in items or ():
        name, sep, value = item.partition("=")
        if not sep or not name:
            raise UVMSError(f"--arg expects NAME=VALUE, got {item!r}")
        assignments[name] = value
    return assignments


def format_limits(lower: np.ndarray, upper: np.ndarray) -> str:
    """Limits of a joint as '[lo, hi]' with unbounded parts shown as '-'."""
    if lower.size != 1 or not (np.isfinite(lower[0]) and np.isfinite(upper[0])) or abs(lower[0]) > 1e30:
        return "-"
    return f"[{lower[0]:+.4f}, {upper[0]:+.4f}]"


def describe(robot: Robot) -> str:
    """The text of ``uvms info``: joints, DOF split, why the base is what it is, frames, mass, end-effector poses."""
    lines = [
        f"model       {robot.name}  ({robot.source})",
        f"base        {robot.base_type}: vehicle DOF {robot.n_vehicle}, arm DOF {robot.n_arm} "
        f"(nq {robot.nq}, nv {robot.nv})",
        f"base rule   {robot.base_reason}",
        f"total mass  {robot.total_mass:.3f} kg",
        "joints",
        f"  {'name':<24} {'type':<27} {'nq':>2} {'nv':>2}  limits [rad or m]",
    ]
    for joint in robot.joints:
        role = "vehicle" if joint.is_vehicle else "arm"
        kind = joint.kind.removeprefix("JointModel") + f" ({role})"
        lines.append(f"  {joint.name:<24} {kind:<27} {joint.nq:>2} {joint.nv:>2}  {format_limits(joint.lower, joint.upper)}")
    body_frames = [f.name for f in robot.model.frames if f.type == pin.FrameType.BODY]
    lines.append(f"frames      {', '.join(body_frames)}")
    q = robot.neutral()
    lines.append("end effectors at the neutral configuration (world frame, m / rad)")
    for frame in robot.ee_frames:
        pose = robot.fk(q, frame)
        rpy = pin.rpy.matrixToRpy(pose.rotation)
        lines.append(f"  {frame:<22} xyz {np.array2string(pose.translation, precision=4, suppress_small=True)}"
                     f"  rpy {np.array2string(rpy, precision=4, suppress_small=True)}")
    lines.append("checks      passed (unit axes, finite numbers, positive masses, inertias and geometry sizes, one tree, "
                 "base)")
    return "\n".join(lines)


def command_info(options: argparse.Namespace) -> int:
    """``uvms info MODEL``: load the model (running its checks) and describe it."""
    robot = load(options.model, base=options.base, args=parse_assignments(options.arg), ee=options.ee or None,
                 package_path=options.package_path)
    say(describe(robot), sys.stdout, lines=True)
    return 0
