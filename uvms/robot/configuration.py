"""Configuration: one configuration q of a robot, with its own Pinocchio data and its kinematics computed once.

Every task, inequality objective and solver reads poses and Jacobians from a :class:`Configuration`, so a
solver step with several tasks runs Pinocchio's kinematics a single time. A configuration owns its
``pinocchio.Data``: two configurations never share state (building one never changes another's pose).

Each quantity is computed at most once per q, when first asked for: the joint placements and Jacobians (one
``computeJointJacobians``), the frame placements (one ``updateFramePlacements``, only for a frame's pose), each
frame's world-aligned Jacobian, and the momentum rows the vehicle
conserves (by default the rigid centroidal map; a controller may pass those of the added-mass-augmented
inertia or of a vehicle held still, :mod:`uvms.robot.kinematics`), from which the generalized Jacobian of
every task follows by the one formula. :meth:`Configuration.update` and :meth:`Configuration.integrate`
move it to another q and forget what was computed.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pinocchio as pin

from . import kinematics
from .robot import Robot, check_robot

#: Momentum rows of a configuration: q (nq,) -> (A_b (r, n_vehicle), A_m (r, n_arm)).
MomentumRows = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]


class Configuration:
    """A configuration q (nq,) of ``robot`` and what Pinocchio computes at it, in data of its own.

    Args:
        robot: the model.
        q: configuration (nq,); checked unless ``check=False`` (hot loops on configurations produced by
            ``pin.integrate``).
        check: validate q (shape, finite, unit quaternion).
        momentum: q -> (A_b, A_m), the conserved momentum rows; None: the rigid centroidal map.

    Attributes:
        robot: the model; model: its ``pinocchio.Model``; data: this configuration's ``pinocchio.Data``; q: the
            configuration (nq,).
    """

    def __init__(self, robot: Robot, q: np.ndarray, *, check: bool = True,
                 momentum: MomentumRows | None = None) -> None:
        self.robot = check_robot(robot, type(self).__name__)
        self.model = robot.model  # read at every update and step
        self.data = robot.model.createData()
        self._momentum = momentum
        self._joint_views: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}  # joint id -> views into data
        self.update(q, check=check)

    def update(self, q: np.ndarray, *, check: bool = True) -> None:
        """Move to the configuration q (nq,); what was computed at the previous one is forgotten."""
        self.q = self.robot.check_configuration(q) if check else q
        self._joints = False  # computeJointJacobians at q
        self._frames = False  # updateFramePlacements at q
        self._jacobians: dict[int, np.ndarray] = {}
        self._centroidal: tuple[np.ndarray, np.ndarray] | None = None

    def integrate(self, v: np.ndarray, dt: float) -> None:
        """Move along the velocity v (nv,) for dt [s]: q <- pin.integrate(q, v dt) (on the manifold)."""
        step = v * dt if v.__class__ is np.ndarray and v.dtype == np.float64 else np.asarray(v, dtype=float) * dt
        self.update(pin.integrate(self.model, self.q, step), check=False)

    def _forward_joints(self) -> None:
        """Joint placements and Jacobians at q, once (``computeJointJacobians`` also runs the FK)."""
        if not self._joints:
            pin.computeJointJacobians(self.model, self.data, self.q)
            self._joints = True

    def _forward(self) -> None:
        """Joint placements and Jacobians, then the frame placements at q, once."""
        if not self._frames:
            self._forward_joints()
            pin.updateFramePlacements(self.model, self.data)
            self._frames = True

    def pose(self, frame_id: int) -> pin.SE3:
        """``transform_frame_to_world`` of a frame (a view into this configuration's data: copy to keep it past
        :meth:`update`)."""
        self._forward()
        return self.data.oMf[frame_id]

    def joint_pose(self, joint_id: int) -> pin.SE3:
        """``transform_joint_to_world`` of a joint (a view, as :meth:`pose`)."""
        self._forward_joints()
        return self.data.oMi[joint_id]

    def joint_arrays(self, joint_id: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(J (6, nv), p (3,), R (3, 3)) at q: every joint's Jacobian in the world frame (Pinocchio's ``data.J``,
        the spatial velocity at the world origin, columns in the order of v; a model without mimic joints) and the
        placement ``transform_joint_to_world`` of joint ``joint_id``, computed once per q.

        Views into this configuration's data, made once per joint: read them before the next :meth:`update` and
        never write them (what a compiled step reads without a Python call per array).
        """
        if not self._joints:
            self._forward_joints()
        views = self._joint_views.get(joint_id)
        if views is None:
            placement = self.data.oMi[joint_id]
            views = self._joint_views[joint_id] = (self.data.J, placement.translation, placement.rotation)
        return views

    def jacobian(self, frame_id: int) -> np.ndarray:
        """World-aligned Jacobian of a frame (6, nv), computed once per configuration."""
        if frame_id not in self._jacobians:
            self._forward_joints()  # getFrameJacobian places the frame from its joint itself
            model = self.model
            self._jacobians[frame_id] = pin.getFrameJacobian(model, self.data, frame_id,
                                                             kinematics.WORLD_ALIGNED).reshape(6, model.nv)
        return self._jacobians[frame_id]

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
                self._forward()  # ccrba overwrites the placements with the same ones: keep them computed first
                self._centroidal = kinematics.centroidal_map_split(self.model, self.data, self.q, robot.base_type,
                                                                   robot.n_vehicle)
        return self._centroidal

    def generalized(self, jacobian: np.ndarray) -> np.ndarray:
        """Generalized version (k, n_arm) of a task Jacobian (k, nv): the vehicle follows momentum.

        Raises:
            ModelCheckError: a fixed base (no vehicle), or a singular vehicle block of the momentum rows.
        """
        a_base, a_arm = self.centroidal_split()
        return kinematics.generalized_jacobian_from_parts(jacobian, a_base, a_arm, self.robot.n_vehicle)
