"""The MPC's optimal control problem on Crocoddyl: the plant as a differential action model and the costs per node.

:class:`PlantActionModel` is a ``crocoddyl.DifferentialActionModelAbstract`` written in Python: its ``calc`` gives
the plant's acceleration (:class:`uvms.control.mpc.prediction.PlantPrediction`: the plant's own equations, the
hydrodynamics included) and its ``calcDiff`` the analytical derivatives; Crocoddyl's integrator (symplectic Euler or
RK4, in C++) makes the nodes. The costs are Crocoddyl's own residuals on the same Pinocchio model:

- ``end_effector``: the end-effector frame's position against the trajectory's at the node's time (quadratic);
- ``posture``: the state against the station (vehicle pose and arm joints at reset, zero velocity), weighted;
- ``effort``: the thrusts [N] and the arm's velocity commands (quadratic);
- ``joint_limits``: a quadratic barrier on the arm joints beyond their limits less a margin (a penalty, not a hard
  constraint: Box-FDDP bounds the inputs only);
- ``tilt``: a quadratic barrier on the base frame's rotation error (roll, pitch) about the level station beyond
  max_tilt (log3 of the level reference's rotation error: roll and pitch to first order);
- ``floor``: optionally, a quadratic barrier on the vehicle origin's world z below a height [m].

The thrust limits are the inputs' bounds (Box-FDDP keeps them exactly); the arm commands are bounded by the joints'
velocity limits. This module imports Crocoddyl; :mod:`uvms.control.mpc` imports it only when an MPC is built.
"""

from __future__ import annotations

import crocoddyl
import numpy as np
import pinocchio as pin

from .prediction import PlantPrediction
from .settings import MPCSettings

#: A bound the barriers treat as none (ActivationBounds takes finite numbers).
UNBOUNDED = 1.0e6


class PlantActionData(crocoddyl.DifferentialActionDataAbstract):
    """A node's data: Pinocchio's for the costs, the costs', and the plant's mass matrix at the node."""

    def __init__(self, model: PlantActionModel) -> None:
        crocoddyl.DifferentialActionDataAbstract.__init__(self, model)
        self.pinocchio = model.state.pinocchio.createData()
        self.multibody = crocoddyl.DataCollectorMultibody(self.pinocchio)
        self.costs = model.costs.createData(self.multibody)
        self.costs.shareMemory(self)  # the costs' gradients and Hessians are this data's
        self.mass = np.eye(model.state.nv)


class PlantActionModel(crocoddyl.DifferentialActionModelAbstract):
    """The plant's dynamics as Crocoddyl's differential action model, with the node's costs.

    Args:
        prediction: the plant and its thrusters' allocation; state: ``crocoddyl.StateMultibody`` of its model.
        costs: the node's ``crocoddyl.CostModelSum``; lower, upper: (nu,) the inputs' bounds.
    """

    def __init__(self, prediction: PlantPrediction, state: crocoddyl.StateMultibody, costs: crocoddyl.CostModelSum,
                 lower: np.ndarray, upper: np.ndarray) -> None:
        crocoddyl.DifferentialActionModelAbstract.__init__(self, state, prediction.nu, costs.nr)
        self.prediction, self.costs = prediction, costs
        self.nq, self.nv = state.nq, state.nv
        self.u_lb, self.u_ub = lower, upper
        self._zero = np.zeros(prediction.nu)

    def calc(self, data: PlantActionData, x: np.ndarray, u: np.ndarray | None = None) -> None:
        q, v = x[:self.nq], x[self.nq:]
        if u is None:  # the terminal node: its costs only
            pin.framesForwardKinematics(self.state.pinocchio, data.pinocchio, q)
            self.costs.calc(data.costs, x)
        else:
            dynamics = self.prediction.evaluate(q, v, u)
            data.xout[:] = dynamics.acceleration
            data.mass = dynamics.mass_matrix
            pin.framesForwardKinematics(self.state.pinocchio, data.pinocchio, q)
            self.costs.calc(data.costs, x, u)
        data.cost = data.costs.cost

    def calcDiff(self, data: PlantActionData, x: np.ndarray, u: np.ndarray | None = None) -> None:  # noqa: N802
        q, v = x[:self.nq], x[self.nq:]
        pin.computeJointJacobians(self.state.pinocchio, data.pinocchio, q)
        if u is None:
            self.costs.calcDiff(data.costs, x)
            return
        da_dq, da_dv, da_du = self.prediction.derivatives(q, v, u, data.xout, data.mass)
        data.Fx[:, :self.nv] = da_dq
        data.Fx[:, self.nv:] = da_dv
        data.Fu[:] = da_du
        self.costs.calcDiff(data.costs, x, u)

    def createData(self) -> PlantActionData:  # noqa: N802
        return PlantActionData(self)


class NodeCosts:
    """The costs of one node and the handles that move their references (the trajectory, the station)."""

    def __init__(self, state: crocoddyl.StateMultibody, nu: int, settings: MPCSettings, frame: int, base_frame: int,
                 x_station: np.ndarray, n_thrusters: int, *, terminal: bool, floor: float | None) -> None:
        model, nv, s = state.pinocchio, state.nv, settings
        nb = 6  # the free-flyer's velocity coordinates
        self.sum = crocoddyl.CostModelSum(state, nu)
        self.target = crocoddyl.ResidualModelFrameTranslation(state, frame, np.zeros(3), nu)
        self.sum.addCost("end_effector", crocoddyl.CostModelResidual(state, self.target),
                         s.terminal_end_effector if terminal else s.end_effector)
        weights = np.concatenate([np.full(3, s.vehicle_position), np.full(3, s.vehicle_attitude),
                                  np.full(nv - nb, s.arm_posture), np.full(nb, s.vehicle_velocity),
                                  np.full(nv - nb, s.arm_velocity)])
        self.station = crocoddyl.ResidualModelState(state, x_station, nu)
        self.sum.addCost("posture", crocoddyl.CostModelResidual(
            state, crocoddyl.ActivationModelWeightedQuad(weights), self.station), 1.0)
        if not terminal:
            effort = np.concatenate([np.full(n_thrusters, s.thrust), np.full(nu - n_thrusters, s.arm_command)])
            self.sum.addCost("effort", crocoddyl.CostModelResidual(
                state, crocoddyl.ActivationModelWeightedQuad(effort), crocoddyl.ResidualModelControl(state, nu)), 1.0)
        if s.joint_limits > 0.0:  # the arm joints (state.zero(): the residual is q_arm itself there)
            lower, upper = np.full(2 * nv, -UNBOUNDED), np.full(2 * nv, UNBOUNDED)
            lower[nb:nv] = model.lowerPositionLimit[7:] + s.joint_margin
            upper[nb:nv] = model.upperPositionLimit[7:] - s.joint_margin
            bad = lower[nb:nv] > upper[nb:nv]  # a joint narrower than twice the margin (the jaw): its middle
            lower[nb:nv][bad] = upper[nb:nv][bad] = 0.5 * (model.lowerPositionLimit[7:] +
                                                           model.upperPositionLimit[7:])[bad]
            self.sum.addCost("joint_limits", crocoddyl.CostModelResidual(
                state, crocoddyl.ActivationModelQuadraticBarrier(crocoddyl.ActivationBounds(lower, upper)),
                crocoddyl.ResidualModelState(state, state.zero(), nu)), s.joint_limits)
        self.level = crocoddyl.ResidualModelFrameRotation(state, base_frame, np.eye(3), nu)
        if s.tilt > 0.0:
            tilt = np.array([s.max_tilt, s.max_tilt, UNBOUNDED])
            self.sum.addCost("tilt", crocoddyl.CostModelResidual(
                state, crocoddyl.ActivationModelQuadraticBarrier(crocoddyl.ActivationBounds(-tilt, tilt)),
                self.level), s.tilt)
        if floor is not None:
            bounds = crocoddyl.ActivationBounds(np.array([-UNBOUNDED, -UNBOUNDED, floor]), np.full(3, UNBOUNDED))
            self.sum.addCost("floor", crocoddyl.CostModelResidual(
                state, crocoddyl.ActivationModelQuadraticBarrier(bounds),
                crocoddyl.ResidualModelFrameTranslation(state, base_frame, np.zeros(3), nu)), s.tilt)

    def move(self, target: np.ndarray, x_station: np.ndarray | None = None, level: np.ndarray | None = None) -> None:
        """Set the end effector's target (3,) [m], and the station (nx,) and the level rotation (3, 3) when given."""
        self.target.reference = target
        if x_station is not None:
            self.station.reference = x_station
        if level is not None:
            self.level.reference = level


def input_bounds(prediction: PlantPrediction, lower: np.ndarray, upper: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The inputs' bounds (nu,): the thrusts' [N] and the arm's velocity commands' (the joints' velocity limits)."""
    limits = np.asarray(prediction.model.velocityLimit[prediction.nb:], dtype=float)
    limits = np.where(np.isfinite(limits) & (limits > 0.0), limits, UNBOUNDED)
    return np.concatenate([lower, -limits]), np.concatenate([upper, limits])


def integrated(model: PlantActionModel, dt: float, integrator: str) -> crocoddyl.ActionModelAbstract:
    """The node of the differential model over dt [s] with Crocoddyl's Euler or RK4."""
    if integrator == "rk4":
        return crocoddyl.IntegratedActionModelRK(model, crocoddyl.RKType.four, dt)
    return crocoddyl.IntegratedActionModelEuler(model, dt)
