"""The CLIK hot path: the CLIK of :func:`~uvms.solvers.clik.clik_velocity` specialized to one 6-D pose task.

:func:`uvms.solvers.clik_velocity` is general (any tasks, weights, variable
damping, generalized Jacobian, joint clamping, diagnostics). ``PoseCLIK`` is
the same law restricted to what a real-time loop needs, its inputs validated
once in the constructor:

    v = z0 + J^+ (xdot_d + K e - J z0),   z0 = -alpha grad S(q)

which equals J^+ (xdot_d + K e) + (I - J^+ J) z0 with the DLS inverse
J^+ = J^T (J J^T + l^2 I)^-1 of the 6-row world-aligned frame Jacobian. The error
is that of a :class:`~uvms.tasks.frame.FrameTask` (position and log3 rotation) and
z0 the gradient of the :class:`~uvms.tasks.joint_limits.JointLimitPotential` over
its :class:`~uvms.robot.limits.Limit`, evaluated on the q entries that limit points at.

A step is three Pinocchio calls (``computeFrameJacobian``, which runs the forward
kinematics, ``log3`` and ``integrate``) around compiled kernels that do the
rest (:func:`~uvms.numerics._kernels.pose.dls_pose_velocity`): building a ``PoseCLIK``
loads it (numba; compiled once per machine and cached).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ..robot.conventions import AXIS_NAMES
from ..robot.kinematics import WORLD_ALIGNED
from ..robot.robot import Robot
from ..tasks.frame import FrameTask
from ..tasks.joint_limits import JointLimitPotential, NullspaceTerms
from ..numerics.checks import check_damping, check_scalar, check_vector
from ..numerics.inverses import SolverInputError

class PoseCLIK:
    """Preallocated CLIK stepper for one 6-D pose task.

    Args:
        robot: the model.
        frame: controlled frame (default: first end effector).
        gain: K > 0 (scalar) [1/s].
        damping: DLS damping l > 0 (keeps the 6x6 system positive definite) [-].
        potential: joint-limit potential S(q) for the null-space term, or None.
        alpha: null-space gain >= 0 [-].

    Attributes:
        task: the pose task (all six axes, log3 orientation error) whose error is driven to zero.
    """

    def __init__(
        self,
        robot: Robot,
        frame: str | None = None,
        *,
        gain: float = 1.0,
        damping: float = 1e-6,
        potential: JointLimitPotential | None = None,
        alpha: float = 0.0,
    ) -> None:
        from ..numerics._kernels.pose import dls_pose_velocity, rotation_to_target  # numba: loaded at first use

        self.gain = check_scalar(gain, "gain", positive=True)
        if check_damping(damping) == 0.0:
            raise SolverInputError("PoseCLIK needs damping > 0; use clik_velocity for the exact pseudo-inverse")
        check_scalar(alpha, "alpha")
        self.robot, self.model, self.data = robot, robot.model, robot.data
        self.task = FrameTask(robot, frame, axes=AXIS_NAMES, orientation="log")
        self.frame_id = self.task.frame_id
        self._damping_squared = float(damping) ** 2
        self._error = np.zeros(6)  # (6,) written by every velocity
        self._target_translation, self._target_rotation = np.zeros(3), np.eye(3)
        self._relative = np.empty((3, 3))  # R_d R^T, only read within a call
        self._feedforward = np.zeros(6)  # (6,)
        self._nullspace = (potential.nullspace_terms(alpha) if potential is not None and alpha != 0.0
                           else NullspaceTerms.none())
        self._kernel, self._to_target = dls_pose_velocity, rotation_to_target

    def set_target(self, pose: pin.SE3, twist: np.ndarray | None = None) -> None:
        """Target pose (``transform_target_to_world``) and feedforward twist [v; omega] (6,) [m/s, rad/s], world axes."""
        feedforward = np.zeros(6) if twist is None else check_vector(twist, "the target twist", 6).copy()
        self.task.set_target(pose)
        self.task.set_target_velocity(feedforward)
        target = self.task.target  # transform_target_to_world, read once
        self._target_translation = np.ascontiguousarray(target.translation)
        self._target_rotation = np.ascontiguousarray(target.rotation)
        self._feedforward = feedforward

    @property
    def error(self) -> np.ndarray:
        """Pose error [p_d - p; log3(R_d R^T)] (6,) [m, rad] in world axes at the last step's configuration."""
        return self._error.copy()

    def _scaled_velocity(self, q: np.ndarray, scale: float) -> np.ndarray:
        """scale * v (nv,) at q: Pinocchio's Jacobian, pose and log3, then the kernel."""
        jacobian = pin.computeFrameJacobian(self.model, self.data, q, self.frame_id, WORLD_ALIGNED)  # (6, nv)
        pose = self.data.oMf[self.frame_id].homogeneous  # transform_frame_to_world, updated by the Jacobian's FK
        self._to_target(pose, self._target_rotation, self._relative)  # R_d R^T (3, 3)
        rotation_error = pin.log3(self._relative)  # (3,)
        q_index, v_index, weights, middle, range_squared, alpha = self._nullspace
        out = np.empty(self.model.nv)
        if not self._kernel(jacobian, pose, self._target_translation, rotation_error, self.gain,
                            self._feedforward, self._damping_squared, q, q_index, v_index, weights, middle,
                            range_squared, alpha, scale, self._error, out):
            raise SolverInputError("DLS system J J^T + l^2 I not positive definite: is the Jacobian finite?")
        return out

    def velocity(self, q: np.ndarray) -> np.ndarray:
        """CLIK velocity v (nv,) at q (trusted: a configuration from ``pin.integrate``)."""
        return self._scaled_velocity(q, 1.0)

    def step(self, q: np.ndarray, dt: float) -> np.ndarray:
        """q after one explicit-Euler step of duration dt [s] on the manifold."""
        return pin.integrate(self.model, q, self._scaled_velocity(q, dt))
