"""KinematicState: one configuration with its kinematics computed once, shared by every task."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from . import kinematics
from .robot import Robot


class KinematicState:
    """Forward kinematics and joint Jacobians of ``robot`` at ``q``, computed once.

    Tasks read poses and world-aligned frame Jacobians from here, so a solver
    step with several tasks runs Pinocchio's kinematics a single time. The
    centroidal map (for the generalized Jacobian) is computed on first use.

    Args:
        robot: the model.
        q: configuration (nq,); checked unless ``check=False`` (for hot loops on
            configurations produced by ``pin.integrate``).
    """

    def __init__(self, robot: Robot, q: np.ndarray, check: bool = True) -> None:
        self.robot = robot
        self.q = robot.check_configuration(q) if check else q
        model, data = robot.model, robot.data
        pin.computeJointJacobians(model, data, self.q)  # also runs forward kinematics
        pin.updateFramePlacements(model, data)
        self._centroidal: tuple[np.ndarray, np.ndarray] | None = None

    def pose(self, frame_id: int) -> pin.SE3:
        """``transform_frame_to_world`` of a frame (a view into the robot's data: copy to keep)."""
        return self.robot.data.oMf[frame_id]

    def jacobian(self, frame_id: int) -> np.ndarray:
        """World-aligned Jacobian of a frame (6, nv)."""
        model = self.robot.model
        return pin.getFrameJacobian(model, self.robot.data, frame_id, kinematics.WORLD_ALIGNED).reshape(6, model.nv)

    def centroidal_split(self) -> tuple[np.ndarray, np.ndarray]:
        """Conserved rows of the centroidal map: A_b (k, n_vehicle), A_m (k, n_arm)."""
        if self._centroidal is None:
            robot = self.robot
            self._centroidal = kinematics.centroidal_map_split(
                robot.model, robot.data, self.q, robot.base_type, robot.n_vehicle)
        return self._centroidal

    def generalized(self, jacobian: np.ndarray) -> np.ndarray:
        """Generalized version (k, n_arm) of a task Jacobian (k, nv): the vehicle follows momentum."""
        a_base, a_arm = self.centroidal_split()
        return kinematics.generalized_jacobian_from_parts(jacobian, a_base, a_arm, self.robot.n_vehicle)
