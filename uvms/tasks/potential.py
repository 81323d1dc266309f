"""The mid-range potential S(q) of hoang2011 eq. 21 (its "joint-limit criterion") and its gradient, over the
bounds of a :class:`uvms.robot.limits.Limit`.

Not an objective: it keeps no bound, it pulls the joints toward the middle of their ranges in the null space of
CLIK's task (``CLIKSolver(potential=..., alpha=...)``) and is what the initial configuration minimizes. The
objective that keeps the joints inside their limits is :class:`uvms.tasks.objectives.joints.JointLimits`; both
read the same :class:`~uvms.robot.limits.Limit` (the model's by default, built once per robot).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..errors import SolverInputError
from ..robot.limits import Limit
from ..robot.robot import Robot, check_robot


class NullspaceTerms(NamedTuple):
    """What the compiled null-space motion z0 = -alpha dS/dv reads
    (:func:`uvms.numerics._kernels.clik.joint_limit_motion_into`).

    The m arm coordinates that q holds itself (continuous joints, stored as (cos, sin), have c = 0 and no
    entry): z0[v_index] = -alpha c (q[q_index] - qbar) / range^2, zero elsewhere.
    """

    q_index: np.ndarray  #: (m,) int64, in q
    v_index: np.ndarray  #: (m,) int64, in the solved columns of v
    weights: np.ndarray  #: c_i (m,)
    middle: np.ndarray  #: qbar_i (m,) [rad or m]
    range_squared: np.ndarray  #: (q_iM - q_im)^2 (m,)
    alpha: float  #: the null-space gain [-]

    @classmethod
    def none(cls) -> NullspaceTerms:
        """No null-space motion (m = 0)."""
        index, values = np.zeros(0, dtype=np.int64), np.zeros(0)
        return cls(index, index, values, values, values, 0.0)


class MidRangePotential:
    """S(q) = 1/2 sum_i c_i ((q_i - qbar_i) / (q_iM - q_im))^2 over the arm joints.

    Its negative gradient, z0 = -alpha dS/dq, projected in the null space of the
    task, pushes the joints toward the middle of their ranges (hoang2011 eq. 20).
    Joints without finite limits get c_i = 0.

    Args:
        robot: the model.
        weights: c_i >= 0, a scalar or (n_arm,); default 1.
        limit: the joint position limits q_im, q_iM (n_arm,); default
            ``Limit.joint_positions(robot)``, the model's (pass one with a margin to aim inside them): the
            same :class:`~uvms.robot.limits.Limit` CLIK's clamping (by default this one) and the ``JointLimits``
            objective read.

    Raises:
        LimitError: a limit that is not the position limits of the arm.
        SolverInputError: weights of the wrong size, negative or not finite.

    Attributes:
        limit: the :class:`~uvms.robot.limits.Limit` read.
        weights: c_i (n_arm,), 0 on unbounded joints.
        middle: qbar_i (n_arm,) [rad or m], 0 on unbounded joints.
        range: q_iM - q_im (n_arm,) [rad or m], 1 on unbounded joints.
    """

    def __init__(self, robot: Robot, weights: float | np.ndarray = 1.0, limit: Limit | None = None) -> None:
        check_robot(robot, "MidRangePotential")
        limit = Limit.arm(robot, limit, "position", "the mid-range potential")
        shape = limit.lower.shape
        weights = np.broadcast_to(np.asarray(weights, dtype=float), shape).copy() if np.ndim(weights) == 0 \
            else np.asarray(weights, dtype=float)
        if weights.shape != shape or not np.all(np.isfinite(weights)) or np.any(weights < 0):
            raise SolverInputError(f"joint-limit weights must be {limit.size} finite numbers >= 0, got {weights!r}")
        bounded = limit.bounded
        self.robot = robot
        self.limit = limit
        self.weights = np.where(bounded, weights, 0.0)
        self.middle = np.where(bounded, limit.middle, 0.0)
        self.range = limit.span
        self._range_squared = self.range**2  # (n_arm,), once: the gradient is evaluated at every controller call

    def value(self, q: np.ndarray) -> float:
        """S(q) [-]."""
        normalized = (self.robot.arm_configuration(q) - self.middle) / self.range
        return float(0.5 * np.sum(self.weights * normalized**2))

    def arm_gradient(self, arm: np.ndarray) -> np.ndarray:
        """dS/dq_arm (n_arm,) at arm joint values."""
        return self.weights * (arm - self.middle) / self._range_squared

    def nullspace_terms(self, alpha: float, first_column: int = 0) -> NullspaceTerms:
        """The arrays of -alpha dS/dv for solved columns that start at v entry ``first_column``, read once."""
        coordinates = np.flatnonzero(self.limit.q_index >= 0)
        return NullspaceTerms(self.limit.q_index[coordinates].astype(np.int64),
                              (coordinates + self.robot.n_vehicle - first_column).astype(np.int64),
                              np.ascontiguousarray(self.weights[coordinates]),
                              np.ascontiguousarray(self.middle[coordinates]),
                              np.ascontiguousarray(self._range_squared[coordinates]), float(alpha))

    def gradient(self, q: np.ndarray) -> np.ndarray:
        """dS/dv (nv,): zero on the vehicle entries."""
        gradient = np.zeros(self.robot.nv)
        gradient[self.robot.n_vehicle:] = self.arm_gradient(self.robot.arm_configuration(q))
        return gradient  # CLIKSolver forms the same from arm_gradient on its already checked q
