"""The CLIK hot path: one frame pose task, DLS, joint-limit null-space term, integration.

:func:`uvms.solvers.clik_velocity` is general (any tasks, weights, variable
damping, generalized Jacobian, joint clamping, diagnostics). ``PoseCLIK`` is
the same law restricted to what a real-time loop needs, with the inputs
validated once in the constructor:

    v = z0 + J^T (J J^T + l^2 I)^-1 (xdot_d + K e - J z0),   z0 = -alpha grad S(q)

which equals J^+ (xdot_d + K e) + (I - J^+ J) z0 with the DLS inverse J^+ of
the 6-row world-aligned frame Jacobian (e: position and log3 rotation errors).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
from scipy.linalg import lapack

from ..robot import Robot
from ..tasks.joint_limits import JointLimitPotential
from ..kinematics import WORLD_ALIGNED
from .inverses import SolverInputError, check_damping


class PoseCLIK:
    """Preallocated CLIK stepper for one 6-D pose task.

    Args:
        robot: the model.
        frame: controlled frame (default: first end effector).
        gain: K > 0 (scalar) [1/s].
        damping: DLS damping l > 0 (keeps the 6x6 system positive definite).
        potential: joint-limit potential S(q) for the null-space term, or None.
        alpha: null-space gain >= 0.
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
        if not (np.isfinite(gain) and gain > 0):
            raise SolverInputError(f"gain must be finite and > 0, got {gain!r}")
        if check_damping(damping) == 0.0:
            raise SolverInputError("PoseCLIK needs damping > 0; use clik_velocity for the exact pseudo-inverse")
        if not (np.isfinite(alpha) and alpha >= 0):
            raise SolverInputError(f"alpha must be finite and >= 0, got {alpha!r}")
        self.robot, self.model, self.data = robot, robot.model, robot.data
        self.frame_id = robot.frame_id(frame)
        self.gain = float(gain)
        self._damping_matrix = damping**2 * np.eye(6)
        self._error = np.zeros(6)
        self._feedforward = np.zeros(6)
        self._target = pin.SE3.Identity()
        self._target_position = np.zeros(3)
        self._has_feedforward = False
        self._nullspace = self._nullspace_terms(potential, alpha)

    def _nullspace_terms(self, potential: JointLimitPotential | None, alpha: float):
        """(q indices, v indices, -alpha c / range^2, middle) of the revolute/prismatic arm joints, or None."""
        if potential is None or alpha == 0.0:
            return None
        q_index, v_index = [], []
        for joint in self.robot.arm_joints:
            if joint.nq == joint.nv == 1:
                q_index.append(joint.idx_q)
                v_index.append(joint.idx_v)
        arm_offset = np.array(v_index) - self.robot.n_vehicle
        scale = -alpha * potential.weights[arm_offset] / potential.range[arm_offset] ** 2
        return np.array(q_index), np.array(v_index), scale, potential.middle[arm_offset]

    def set_target(self, pose: pin.SE3, twist: np.ndarray | None = None) -> None:
        """Target pose (``transform_target_to_world``) and feedforward twist [v; omega] (6,), world axes."""
        self._target = pose.copy()
        self._target_position = np.array(pose.translation)
        self._feedforward = np.zeros(6) if twist is None else np.asarray(twist, dtype=float).copy()
        if self._feedforward.shape != (6,) or not np.all(np.isfinite(self._feedforward)):
            raise SolverInputError(f"the target twist must be 6 finite numbers, got {twist!r}")
        self._has_feedforward = bool(np.any(self._feedforward))

    @property
    def error(self) -> np.ndarray:
        """Pose error [p_d - p; log3(R_d R^T)] (6,) in world axes at the last step's configuration."""
        return self._error.copy()

    def velocity(self, q: np.ndarray) -> np.ndarray:
        """CLIK velocity v (nv,) at q (trusted: a configuration from ``pin.integrate``)."""
        jacobian = pin.computeFrameJacobian(self.model, self.data, q, self.frame_id, WORLD_ALIGNED).reshape(6, -1)
        pose = self.data.oMf[self.frame_id]  # updated by computeFrameJacobian in world-aligned axes
        error = self._error
        error[:3] = self._target_position - pose.translation
        error[3:] = pin.log3((self._target * pose.inverse()).rotation)  # R_d R^T, computed in C++
        command = self.gain * error
        if self._has_feedforward:
            command += self._feedforward
        z0 = None
        if self._nullspace is not None:
            q_index, v_index, scale, middle = self._nullspace
            z0 = np.zeros(self.model.nv)
            z0[v_index] = scale * (q[q_index] - middle)
            command -= jacobian @ z0
        system = jacobian @ jacobian.T
        system += self._damping_matrix
        _, solution, info = lapack.dposv(system, command)
        if info != 0:  # cannot happen with damping > 0 and finite J; never return garbage
            raise SolverInputError(f"DLS system not positive definite (LAPACK info {info})")
        velocity = jacobian.T @ solution
        if z0 is not None:
            velocity += z0
        return velocity

    def step(self, q: np.ndarray, dt: float) -> np.ndarray:
        """q after one explicit-Euler step of duration dt [s] on the manifold."""
        return pin.integrate(self.model, q, self.velocity(q) * dt)
