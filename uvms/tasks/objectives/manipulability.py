"""Manipulability of a frame above a minimum, its gradient by central differences on the manifold."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from ...errors import ObjectiveError
from ...robot.configuration import Configuration
from ...robot.kinematics import WORLD_ALIGNED, axis_rows, manipulability_of
from ...robot.robot import Robot
from .base import Inequality, finite_number

POSITION_AXES = ("x", "y", "z")


class Manipulability(Inequality):
    """Yoshikawa's manipulability of the arm at a frame, m(q) = sqrt(det(J J^T)) >= ``min`` (1 row).

    J holds the position rows (``axes``) and the arm columns of the frame's world-aligned Jacobian: the
    dexterity of the arm, which the vehicle's pose does not change (a rotation leaves the singular values
    alone), so the gradient has zero vehicle entries. Computed as the product of the singular values.

    The gradient dm/dv_i (the Jacobian row) is a central difference on the configuration manifold,
    (m(integrate(q, h e_i)) - m(integrate(q, -h e_i))) / 2h over the arm entries, with ``step`` h:
    2 n_arm Jacobian evaluations, in a Pinocchio data of its own (the state's data stays untouched).
    Truncation error O(h^2), rounding O(eps / h): about 1e-9 relative at h = 1e-6.

    Args:
        robot: the model.
        frame: a frame name (default: the first end effector).
        min: the smallest manipulability allowed [m^k for k position rows].
        band: activation band > 0 [same unit].
        gain: reference gain [1/s].
        axes: position axes of J (default: those of ``robot.base.task_axes``: x, y, z; x, y when planar).
        step: finite-difference step h [rad or m] > 0.
        shape: activation shape, "cosine" or "step".
        name: the name results report (default ``manipulability(<frame>)``).
    """

    type_name = "manipulability"
    unit = "manipulability"
    min_metric = "min_manipulability"

    def __init__(self, robot: Robot, frame: str | None = None, min: float = 0.0, band: float = 0.01,  # noqa: A002
                 gain: float = 1.0, axes: Sequence[str] | None = None, step: float = 1e-6, shape: str = "cosine",
                 name: str | None = None) -> None:
        self.robot = robot
        self.frame = frame or robot.ee_frames[0]
        self.name = name or f"manipulability({self.frame})"
        self.frame_id = robot.frame_id(frame)
        axes = tuple(axes) if axes is not None else tuple(a for a in robot.base.task_axes if a in POSITION_AXES)
        unknown = [a for a in axes if a not in POSITION_AXES]
        if unknown or not axes:
            raise ObjectiveError(f"{self.name}: axes must be position axes among {', '.join(POSITION_AXES)}, "
                                 f"got {list(axes)}")
        if robot.n_arm == 0:
            raise ObjectiveError(f"{self.name}: {robot.name} has no arm joints")
        self.rows_of_jacobian = axis_rows(axes)
        self.step = finite_number(step, f"{self.name}: step", positive=True)
        self.min = finite_number(min, f"{self.name}: min")
        self._data = robot.model.createData()
        self._set_valid_set([self.min], [np.inf], finite_number(band, f"{self.name}: band", positive=True),
                            gain, shape)

    def _of_jacobian(self, jacobian: np.ndarray) -> float:
        return manipulability_of(jacobian[self.rows_of_jacobian, self.robot.n_vehicle:])

    def at(self, q: np.ndarray) -> float:
        """m(q) [-], in this objective's own Pinocchio data."""
        model = self.robot.model
        jacobian = pin.computeFrameJacobian(model, self._data, q, self.frame_id, WORLD_ALIGNED)
        return self._of_jacobian(jacobian)

    def value(self, state: Configuration) -> np.ndarray:
        return np.array([self._of_jacobian(state.jacobian(self.frame_id))])

    def jacobian(self, state: Configuration) -> np.ndarray:
        model, robot = self.robot.model, self.robot
        gradient = np.zeros((1, robot.nv))
        tangent = np.zeros(robot.nv)
        for index in range(robot.n_vehicle, robot.nv):
            tangent[index] = self.step
            ahead = self.at(pin.integrate(model, state.q, tangent))
            behind = self.at(pin.integrate(model, state.q, -tangent))
            tangent[index] = 0.0
            gradient[0, index] = (ahead - behind) / (2.0 * self.step)
        return gradient
