"""KinematicState: one configuration with its kinematics computed once, shared by every task.

Two forms, one interface (``q``, ``pose``, ``jacobian``, ``centroidal_split``, ``generalized``):

* :class:`KinematicState` runs Pinocchio's joint Jacobians once for every frame (several tasks);
* :class:`FrameState` computes the Jacobian of each frame asked for on its own (``computeFrameJacobian``),
  in a Pinocchio data of its own: the form of a controller of one frame (GJM control).

Both take the momentum rows the vehicle conserves (``momentum``): by default the rigid centroidal map;
a controller may pass those of the added-mass-augmented inertia or of a vehicle held still
(:mod:`uvms.robot.kinematics`), and the generalized Jacobian of every task follows from them by the one formula.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pinocchio as pin

from . import kinematics
from .robot import Robot, check_robot

#: Momentum rows of a configuration: q (nq,) -> (A_b (r, n_vehicle), A_m (r, n_arm)).
MomentumRows = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]


class KinematicState:
    """Forward kinematics and joint Jacobians of ``robot`` at ``q``, computed once.

    Tasks read poses and world-aligned frame Jacobians from here, so a solver
    step with several tasks runs Pinocchio's kinematics a single time. The
    momentum rows (for the generalized Jacobian) are computed on first use.

    Args:
        robot: the model.
        q: configuration (nq,); checked unless ``check=False`` (for hot loops on
            configurations produced by ``pin.integrate``).
        momentum: q -> (A_b, A_m), the conserved momentum rows; None: the rigid centroidal map.
    """

    def __init__(self, robot: Robot, q: np.ndarray, check: bool = True, *, momentum: MomentumRows | None = None) -> None:
        self.robot = robot
        self.q = check_robot(robot, type(self).__name__).check_configuration(q) if check else q
        self._momentum = momentum
        self._centroidal: tuple[np.ndarray, np.ndarray] | None = None
        self._compute()

    def _compute(self) -> None:
        model, data = self.robot.model, self.robot.data
        pin.computeJointJacobians(model, data, self.q)  # also runs forward kinematics
        pin.updateFramePlacements(model, data)

    def pose(self, frame_id: int) -> pin.SE3:
        """``transform_frame_to_world`` of a frame (a view into the robot's data: copy to keep)."""
        return self.robot.data.oMf[frame_id]

    def jacobian(self, frame_id: int) -> np.ndarray:
        """World-aligned Jacobian of a frame (6, nv)."""
        model = self.robot.model
        return pin.getFrameJacobian(model, self.robot.data, frame_id, kinematics.WORLD_ALIGNED).reshape(6, model.nv)

    def centroidal_split(self) -> tuple[np.ndarray, np.ndarray]:
        """Conserved momentum rows: A_b (k, n_vehicle), A_m (k, n_arm) (the centroidal map unless chosen).

        Raises:
            ModelCheckError: a fixed base: the model has no vehicle whose momentum is conserved.
        """
        if self._centroidal is None:
            robot = self.robot
            if self._momentum is not None:
                self._centroidal = self._momentum(self.q)
            else:
                self._centroidal = kinematics.centroidal_map_split(
                    robot.model, robot.data, self.q, robot.base_type, robot.n_vehicle)
        return self._centroidal

    def generalized(self, jacobian: np.ndarray) -> np.ndarray:
        """Generalized version (k, n_arm) of a task Jacobian (k, nv): the vehicle follows momentum.

        Raises:
            ModelCheckError: a fixed base (no vehicle), or a singular vehicle block of the momentum rows.
        """
        a_base, a_arm = self.centroidal_split()
        return kinematics.generalized_jacobian_from_parts(jacobian, a_base, a_arm, self.robot.n_vehicle)


class FrameState(KinematicState):
    """The state of a controller of one or a few frames, each Jacobian computed on its own, in its own data.

    Args:
        robot: the model; q: configuration (nq,) (checked unless ``check=False``).
        data: the Pinocchio data to compute in (the controller's own; None: a new one).
        momentum: q -> (A_b, A_m), the conserved momentum rows; None: the rigid centroidal map.
    """

    def __init__(self, robot: Robot, q: np.ndarray, check: bool = True, *, data: pin.Data | None = None,
                 momentum: MomentumRows | None = None) -> None:
        self.data = robot.model.createData() if data is None else data
        self._frames: dict[int, tuple[np.ndarray, pin.SE3]] = {}
        super().__init__(robot, q, check, momentum=momentum)

    def _compute(self) -> None:
        """Nothing until a frame is asked for."""

    def _frame(self, frame_id: int) -> tuple[np.ndarray, pin.SE3]:
        if frame_id not in self._frames:
            model, data = self.robot.model, self.data
            jacobian = pin.computeFrameJacobian(model, data, self.q, frame_id, kinematics.WORLD_ALIGNED)
            self._frames[frame_id] = (jacobian.reshape(6, model.nv), data.oMf[frame_id].copy())
        return self._frames[frame_id]

    def pose(self, frame_id: int) -> pin.SE3:
        """``transform_frame_to_world`` of a frame (a copy, kept with this state)."""
        return self._frame(frame_id)[1]

    def jacobian(self, frame_id: int) -> np.ndarray:
        """World-aligned Jacobian of a frame (6, nv) (``computeFrameJacobian``)."""
        return self._frame(frame_id)[0]

    def centroidal_split(self) -> tuple[np.ndarray, np.ndarray]:
        """Conserved momentum rows A_b (k, n_vehicle), A_m (k, n_arm), computed in this state's data."""
        if self._centroidal is None and self._momentum is None:
            robot = self.robot
            self._centroidal = kinematics.centroidal_map_split(robot.model, self.data, self.q, robot.base_type,
                                                               robot.n_vehicle)
        return super().centroidal_split()
