"""Vehicle velocity constraints: at rest, heading toward a current, holding depth."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pinocchio as pin

from ..errors import UVMSError
from ..robot.bases import BASE_TYPES
from ..robot.configuration import Configuration
from ..robot.conventions import wrap_angle
from ..robot.robot import Robot, check_robot
from .task import Task

#: Names of the vehicle velocity entries (body twist in local FLU axes), per base type with a vehicle.
VELOCITY_NAMES = {name: base.velocity_names for name, base in BASE_TYPES.items() if base.nv}


class VehicleTask(Task):
    """Impose vehicle velocities and, optionally, a heading and a depth.

    Rows, in this order: one per imposed body velocity (``velocities``), then
    the world yaw (``heading``) and the world z (``depth``). Imposed velocities
    have no error; heading and depth rows have error (target - current), so
    with CLIK gain K the vehicle turns at K * (heading - yaw), as santos2006
    aligns its vehicle with the ocean current.

    Args:
        robot: a model with a floating or planar base.
        velocities: {name: value} with names ``vx, vy, vz, wx, wy, wz`` (floating) or
            ``vx, vy, wz`` (planar) [m/s, rad/s], body FLU axes.
        heading: target world yaw of the vehicle [rad] (ENU, about z up), or None.
        depth: target world z of the vehicle [m] (floating base only), or None.
    """

    def __init__(
        self,
        robot: Robot,
        velocities: Mapping[str, float] | None = None,
        heading: float | None = None,
        depth: float | None = None,
    ) -> None:
        check_robot(robot, "VehicleTask")
        if robot.base_type not in VELOCITY_NAMES:
            raise UVMSError(f"{robot.name} has a fixed base: a vehicle task needs a floating or planar base")
        names = VELOCITY_NAMES[robot.base_type]
        velocities = dict(velocities or {})
        unknown = sorted(set(velocities) - set(names))
        if unknown:
            raise UVMSError(f"unknown vehicle velocities {unknown}; valid for "
                            f"a {robot.base_type} base: {', '.join(names)}")
        if depth is not None and robot.base_type != "floating":
            raise UVMSError("depth can only be held by a floating base")
        values = [heading, depth, *velocities.values()]
        if any(value is not None and not np.isfinite(value) for value in values):
            raise UVMSError(f"vehicle task values must be finite, got {values}")
        self.robot = robot
        self.velocity_indices = [names.index(name) for name in velocities]
        self.velocity_values = np.array(list(velocities.values()), dtype=float)
        self.heading, self.depth = heading, depth
        self.dim = len(self.velocity_indices) + (heading is not None) + (depth is not None)
        if self.dim == 0:
            raise UVMSError("a vehicle task needs at least one velocity, a heading or a depth")
        # the imposed velocities' rows (k, nv), constant: a task of velocities alone reads no pose
        self._velocity_rows = np.zeros((len(self.velocity_indices), robot.nv))
        self._velocity_rows[np.arange(len(self.velocity_indices)), self.velocity_indices] = 1.0
        # a task of velocities alone hands out these rows and its zero error as they are (as a joint task its rows;
        # writable: a read-only array is another type to the kernels that read it)
        self._no_error = np.zeros(self.dim)

    @classmethod
    def at_rest(cls, robot: Robot) -> VehicleTask:
        """Every vehicle velocity zero."""
        return cls(robot, velocities=dict.fromkeys(VELOCITY_NAMES[robot.base_type], 0.0))

    def _rotation_and_rpy(self, state: Configuration) -> tuple[np.ndarray, np.ndarray]:
        rotation = state.joint_pose(1).rotation
        return rotation, pin.rpy.matrixToRpy(rotation)

    def error(self, state: Configuration) -> np.ndarray:
        error = np.zeros(self.dim)
        row = len(self.velocity_indices)
        rotation, rpy = self._rotation_and_rpy(state)
        if self.heading is not None:
            error[row] = wrap_angle(self.heading - rpy[2])
            row += 1
        if self.depth is not None:
            error[row] = self.depth - state.joint_pose(1).translation[2]
        return error

    def jacobian(self, state: Configuration) -> np.ndarray:
        robot = self.robot
        jacobian = np.zeros((self.dim, robot.nv))
        for row, index in enumerate(self.velocity_indices):
            jacobian[row, index] = 1.0
        row = len(self.velocity_indices)
        rotation, rpy = self._rotation_and_rpy(state)
        if self.heading is not None:
            if robot.base_type == "planar":
                jacobian[row, 2] = 1.0
            else:  # yaw rate = [E(rpy)^-1 R omega_local]_z
                jacobian[row, 3:6] = (pin.rpy.computeRpyJacobianInverse(rpy, pin.WORLD) @ rotation)[2]
            row += 1
        if self.depth is not None:
            jacobian[row, 0:3] = rotation[2]  # world zdot = [R v_local]_z
        return jacobian

    def terms(self, state: Configuration) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(jacobian (k, nv), error (k,), feedforward (k,)); velocities alone (no heading, no depth): the constant
        rows and zero error (the task's own arrays: never to be written) and the imposed velocities, without reading
        the vehicle's pose."""
        if self.heading is None and self.depth is None:
            return self._velocity_rows, self._no_error, self.velocity_values.copy()
        return self.jacobian(state), self.error(state), self.feedforward(state)

    def feedforward(self, state: Configuration) -> np.ndarray:  # noqa: ARG002 - constant
        feedforward = np.zeros(self.dim)
        feedforward[: len(self.velocity_values)] = self.velocity_values
        return feedforward
