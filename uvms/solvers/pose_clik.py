"""The CLIK hot path: the CLIK of :func:`~uvms.solvers.clik.clik_velocity` specialized to one 6-D pose task.

:func:`uvms.solvers.clik_velocity` is general (any tasks, weights, variable
damping, generalized Jacobian, joint clamping, diagnostics). ``PoseCLIK`` is
the same law restricted to what a real-time loop needs, its inputs validated
once in the constructor and its buffers allocated once:

    v = z0 + J^+ (xdot_d + K e - J z0),   z0 = -alpha grad S(q)

which equals J^+ (xdot_d + K e) + (I - J^+ J) z0 with the DLS inverse J^+ of
the 6-row world-aligned frame Jacobian. It shares the pieces of the general
CLIK rather than repeating them: the error is that of a
:class:`~uvms.tasks.frame.FrameTask` (position and log3 rotation), J^+ is the
normal-equation DLS of :func:`~uvms.solvers.inverses.dls_solve`, and z0 is the
gradient of the :class:`~uvms.tasks.joint_limits.JointLimitPotential` over its
:class:`~uvms.limits.Limit`, evaluated on the q entries that limit points at.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ..conventions import AXIS_NAMES
from ..kinematics import WORLD_ALIGNED
from ..limits import index_or_slice
from ..robot import Robot
from ..tasks.frame import FrameTask, log_pose_error
from ..tasks.joint_limits import JointLimitPotential
from .checks import check_damping, check_scalar, check_vector
from .inverses import SolverInputError, dls_solve


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
        self.gain = check_scalar(gain, "gain", positive=True)
        if check_damping(damping) == 0.0:
            raise SolverInputError("PoseCLIK needs damping > 0; use clik_velocity for the exact pseudo-inverse")
        check_scalar(alpha, "alpha")
        self.robot, self.model, self.data = robot, robot.model, robot.data
        self._nv = robot.nv
        self.task = FrameTask(robot, frame, axes=AXIS_NAMES, orientation="log")
        self.frame_id = self.task.frame_id
        self._damping_matrix = float(damping) ** 2 * np.eye(6)  # (6, 6) l^2 I
        self._error = np.zeros(6)  # (6,)
        self._feedforward = np.zeros(6)  # (6,)
        self._target = pin.SE3.Identity()
        self._target_translation, self._target_rotation = np.zeros(3), np.eye(3)
        self._has_feedforward = False
        self._nullspace = self._nullspace_terms(potential, alpha)
        self._z0 = np.zeros(self._nv)  # (nv,) the null-space motion's buffer

    def _nullspace_terms(self, potential: JointLimitPotential | None, alpha: float):
        """(q indices, v indices (slices when consecutive), -alpha c / range^2, middle) of the arm coordinates q holds
        itself, or None.

        z0[v_index] = scale (q[q_index] - middle) is -alpha grad S(q) of the potential
        (continuous joints, which q stores as (cos, sin), have c = 0 and no entry).
        """
        if potential is None or alpha == 0.0:
            return None
        limit = potential.limit
        coordinates = np.flatnonzero(limit.q_index >= 0)
        scale = -alpha * potential.weights[coordinates] / potential.range[coordinates] ** 2
        # slices where the coordinates are consecutive (the common case): views, not gathers
        return (index_or_slice(limit.q_index[coordinates]), index_or_slice(coordinates + self.robot.n_vehicle), scale,
                potential.middle[coordinates])

    def set_target(self, pose: pin.SE3, twist: np.ndarray | None = None) -> None:
        """Target pose (``transform_target_to_world``) and feedforward twist [v; omega] (6,) [m/s, rad/s], world axes."""
        feedforward = np.zeros(6) if twist is None else check_vector(twist, "the target twist", 6).copy()
        self.task.set_target(pose)
        self.task.set_target_velocity(feedforward)
        self._target = self.task.target
        self._target_translation, self._target_rotation = self._target.translation, self._target.rotation  # read once
        self._feedforward = feedforward
        self._has_feedforward = bool(np.any(feedforward))

    @property
    def error(self) -> np.ndarray:
        """Pose error [p_d - p; log3(R_d R^T)] (6,) [m, rad] in world axes at the last step's configuration."""
        return self._error.copy()

    def velocity(self, q: np.ndarray) -> np.ndarray:
        """CLIK velocity v (nv,) at q (trusted: a configuration from ``pin.integrate``)."""
        jacobian = pin.computeFrameJacobian(self.model, self.data, q, self.frame_id, WORLD_ALIGNED)  # (6, nv)
        pose = self.data.oMf[self.frame_id]  # updated by computeFrameJacobian in world-aligned axes
        error = self._error = log_pose_error(self._target_translation, self._target_rotation, pose)  # (6,)
        command = self.gain * error
        if self._has_feedforward:
            command += self._feedforward
        z0 = None
        if self._nullspace is not None:
            q_index, v_index, scale, middle = self._nullspace
            z0 = self._z0  # zero outside v_index; only read within this call
            z0[v_index] = scale * (q[q_index] - middle)
            command -= jacobian.dot(z0)
        velocity = dls_solve(jacobian, command, self._damping_matrix)  # (nv,)
        if z0 is not None:
            velocity += z0
        return velocity

    def step(self, q: np.ndarray, dt: float) -> np.ndarray:
        """q after one explicit-Euler step of duration dt [s] on the manifold."""
        return pin.integrate(self.model, q, self.velocity(q) * dt)
