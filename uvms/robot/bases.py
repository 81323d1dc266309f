"""The three kinds of vehicle base and every fact that depends on the kind, in one table.

A UVMS's vehicle is the root joint of its model: a 6-DOF free flyer ("floating"), a planar joint in the
world's x-y plane ("planar", x, y and yaw), or none ("fixed": an arm on a fixed base). Modules ask
``robot.base`` (a :class:`BaseType`) instead of keeping their own per-kind tables.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import pinocchio as pin

from .conventions import AXIS_NAMES


@dataclass(frozen=True)
class BaseType:
    """One kind of vehicle base.

    Attributes:
        name: "floating", "planar" or "fixed".
        nq: entries of q the vehicle holds (7: xyz + quaternion, 4: x, y, cos, sin, 0).
        nv: entries of v the vehicle holds (its degrees of freedom).
        pose_names: the vehicle pose as users give it (``Robot.configuration(base=...)``, ``base_values``).
        velocity_names: the vehicle twist entries of v, in the vehicle's local axes.
        pose_labels, velocity_labels: axis labels of figures [units] (the twist in the body's FLU axes, not
            Fossen's u, v, w, p, q, r of FRD).
        task_axes: the task axes that make sense for this base (all six, or x, y, yaw).
        conserved_momentum_rows: rows of the centroidal momentum [linear; angular] the vehicle cannot exchange
            with the world through its joint (the generalized Jacobian uses them).
        root_joint: the Pinocchio joint model of the vehicle (None for a fixed base).
    """

    name: str
    nq: int
    nv: int
    pose_names: tuple[str, ...]
    velocity_names: tuple[str, ...]
    pose_labels: tuple[str, ...]
    velocity_labels: tuple[str, ...]
    task_axes: tuple[str, ...]
    conserved_momentum_rows: tuple[int, ...]
    root_joint: Callable[[], pin.JointModel] | None


BASE_TYPES: dict[str, BaseType] = {
    "floating": BaseType(
        name="floating", nq=7, nv=6,
        pose_names=("x", "y", "z", "roll", "pitch", "yaw"),
        velocity_names=("vx", "vy", "vz", "wx", "wy", "wz"),
        pose_labels=("x [m]", "y [m]", "z [m]", "roll [rad]", "pitch [rad]", "yaw [rad]"),
        velocity_labels=("vx [m/s]", "vy [m/s]", "vz [m/s]", "ωx [rad/s]", "ωy [rad/s]", "ωz [rad/s]"),
        task_axes=AXIS_NAMES, conserved_momentum_rows=(0, 1, 2, 3, 4, 5), root_joint=pin.JointModelFreeFlyer,
    ),
    "planar": BaseType(
        name="planar", nq=4, nv=3,
        pose_names=("x", "y", "yaw"),
        velocity_names=("vx", "vy", "wz"),
        pose_labels=("x [m]", "y [m]", "psi [rad]"),
        velocity_labels=("vx [m/s]", "vy [m/s]", "ωz [rad/s]"),
        task_axes=("x", "y", "yaw"), conserved_momentum_rows=(0, 1, 5), root_joint=pin.JointModelPlanar,
    ),
    "fixed": BaseType(
        name="fixed", nq=0, nv=0, pose_names=(), velocity_names=(), pose_labels=(), velocity_labels=(),
        task_axes=AXIS_NAMES, conserved_momentum_rows=(), root_joint=None,
    ),
}
