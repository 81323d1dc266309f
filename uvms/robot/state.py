"""The kinematics of a model at one configuration, each quantity computed once per q, in a ``pinocchio.Data`` of
its own: the one way uvms computes poses and Jacobians.

:class:`KinematicState` knows only the Pinocchio model; :class:`~uvms.robot.configuration.Configuration` (the state
tasks, objectives and solvers read) adds the robot, the checks of q and the momentum the vehicle conserves, and
:meth:`Robot.fk <uvms.robot.robot.Robot.fk>` / :meth:`Robot.jacobian <uvms.robot.robot.Robot.jacobian>` are
conveniences over the robot's own state (by frame name, one q per call).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from . import kinematics


class KinematicState:
    """Poses and world-aligned Jacobians of ``model`` at a configuration q, each computed at most once per q.

    The joint placements and Jacobians come from one ``computeJointJacobians`` (which also runs the forward
    kinematics); a frame's placement from one ``updateFramePlacement`` when first asked; a frame's Jacobian from
    one ``getFrameJacobian``. :meth:`update` moves to another q and forgets them.

    Args:
        model: the Pinocchio model; its data is created here.

    Attributes:
        model: the model; data: this state's ``pinocchio.Data``; q: the configuration (nq,) (None before the first
            :meth:`update`).
    """

    def __init__(self, model: pin.Model) -> None:
        self.model = model  # read at every update and step
        self.data = model.createData()
        self.q: np.ndarray | None = None
        self._placed: set[int] = set()  # frames placed by updateFramePlacement at q
        self._jacobians: dict[int, np.ndarray] = {}
        self._joint_views: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}  # joint id -> views into data

    def update(self, q: np.ndarray) -> None:
        """Move to the configuration q (nq,), unchecked; what was computed at the previous one is forgotten."""
        self.q = q
        self._joints = False  # computeJointJacobians at q
        if self._placed:  # emptied, not made anew: an update is in every loop
            self._placed.clear()
        if self._jacobians:
            self._jacobians.clear()  # the arrays handed out stay theirs: each is made anew at its q

    def _forward_joints(self) -> None:
        """Joint placements and Jacobians at q, once (``computeJointJacobians`` also runs the FK)."""
        if not self._joints:
            pin.computeJointJacobians(self.model, self.data, self.q)
            self._joints = True

    def pose(self, frame_id: int) -> pin.SE3:
        """``transform_frame_to_world`` of a frame (a view into this state's data: copy to keep it past
        :meth:`update`)."""
        if frame_id not in self._placed:
            if not self._joints:
                self._forward_joints()
            pin.updateFramePlacement(self.model, self.data, frame_id)  # returns a copy: the view is read below
            self._placed.add(frame_id)
        return self.data.oMf[frame_id]

    def joint_pose(self, joint_id: int) -> pin.SE3:
        """``transform_joint_to_world`` of a joint (a view, as :meth:`pose`)."""
        self._forward_joints()
        return self.data.oMi[joint_id]

    def joint_arrays(self, joint_id: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(J (6, nv), p (3,), R (3, 3)) at q: every joint's Jacobian in the world frame (Pinocchio's ``data.J``,
        the spatial velocity at the world origin, columns in the order of v; a model without mimic joints) and the
        placement ``transform_joint_to_world`` of joint ``joint_id``, computed once per q.

        Views into this state's data, made once per joint: read them before the next :meth:`update` and never
        write them (what a compiled step reads without a Python call per array).
        """
        if not self._joints:
            self._forward_joints()
        views = self._joint_views.get(joint_id)
        if views is None:
            placement = self.data.oMi[joint_id]
            views = self._joint_views[joint_id] = (self.data.J, placement.translation, placement.rotation)
        return views

    def jacobian(self, frame_id: int) -> np.ndarray:
        """World-aligned Jacobian of a frame (6, nv), computed once per q (a view: copy to keep it past
        :meth:`update`)."""
        if frame_id not in self._jacobians:
            self._forward_joints()  # getFrameJacobian places the frame from its joint itself
            model = self.model
            # reshape: Pinocchio's binding returns a one-column matrix as a (6,) vector when nv = 1
            self._jacobians[frame_id] = pin.getFrameJacobian(model, self.data, frame_id,
                                                             kinematics.WORLD_ALIGNED).reshape(6, model.nv)
        return self._jacobians[frame_id]

    def centroidal_rows(self, base_type: str, n_vehicle: int) -> tuple[np.ndarray, np.ndarray]:
        """The rigid centroidal map's conserved rows at q, split: A_b (k, n_vehicle), A_m (k, n_arm) (computed at
        every call: :class:`~uvms.robot.configuration.Configuration` keeps them).

        Raises:
            NoVehicleError: a fixed base.
        """
        self._forward_joints()  # ccrba overwrites the placements with the same ones: keep them computed first
        return kinematics.centroidal_map_split(self.model, self.data, self.q, base_type, n_vehicle)
