"""The MPC's optimal control problem on Crocoddyl: the plant as a differential action model and the costs per node.

:class:`PlantActionModel` is a ``crocoddyl.DifferentialActionModelAbstract`` written in Python: its ``calc`` gives
the plant's acceleration (:class:`uvms.control.mpc.prediction.PlantPrediction`: the plant's own equations, the
hydrodynamics included) and its ``calcDiff`` the analytical derivatives; Crocoddyl's integrator (symplectic Euler or
RK4, in C++) makes the nodes. The costs are Crocoddyl's own residuals on the same Pinocchio model:

- ``end_effector``: the end-effector frame's position against the trajectory's at the node's time (quadratic);
- ``posture``: the state against the station (vehicle pose and arm joints at reset, zero velocity), weighted;
- ``effort``: the thrusts [N] and the arm's velocity commands (quadratic);

The scenario's inequality objectives are the node's constraint rows (:mod:`uvms.control.mpc.constraints`): CSQP's
constraints g, or with Box-FDDP exact quadratic penalties; the thrust limits are the inputs' bounds (CSQP: rows g = u;
Box-FDDP: its box); the arm commands are bounded by the joints' velocity limits.
This module imports Crocoddyl; :mod:`uvms.control.mpc` imports it only when an MPC is built.
"""

from __future__ import annotations

import crocoddyl
import numpy as np
import pinocchio as pin

from ...errors import NumericalError
from .constraints import UNBOUNDED, NodeConstraints
from .prediction import PlantPrediction
from .settings import MPCSettings

#: A node's cost where its state or input is not finite or beyond :data:`UNBOUNDED` (a line-search trial along the
#: step of a QP that diverged): large and finite. Crocoddyl's check of a trial's cost (NaN, inf or >= 1e30) throws
#: inside CSQP's OpenMP loop, where no handler catches it: the process aborts. So the node reports this cost,
#: every constraint row violated by UNBOUNDED and no acceleration; the line search then rejects the trial.
REJECTED_COST = 1.0e20


class PlantActionData(crocoddyl.DifferentialActionDataAbstract):
    """A node's data: Pinocchio's for the costs, the costs', the plant's mass matrix at the node, the constraints'
    configuration and the objectives' rows and Jacobian there."""

    def __init__(self, model: PlantActionModel) -> None:
        crocoddyl.DifferentialActionDataAbstract.__init__(self, model)
        self.pinocchio = model.state.pinocchio.createData()
        self.multibody = crocoddyl.DataCollectorMultibody(self.pinocchio)
        self.costs = model.costs.createData(self.multibody)
        self.costs.shareMemory(self)  # the costs' gradients and Hessians are this data's
        self.mass = np.eye(model.state.nv)
        self.acceleration = np.zeros(model.state.nv)
        nv = model.state.nv
        self.derivatives = np.zeros((nv, nv)), np.zeros((nv, nv)), np.zeros((nv, model.nu))
        self.configuration = model.constraints.configuration()
        self.rows, self.rows_jacobian = np.zeros(0), np.zeros((0, model.state.nv))
        self.rejected = False  # the last calc's point was out of range (REJECTED_COST)


class PlantActionModel(crocoddyl.DifferentialActionModelAbstract):
    """The plant's dynamics as Crocoddyl's differential action model, with the node's costs.

    Args:
        prediction: the plant and its thrusters' allocation; state: ``crocoddyl.StateMultibody`` of its model.
        costs: the node's ``crocoddyl.CostModelSum``; lower, upper: (nu,) the inputs' bounds.
        constraints: the node's rows; penalty: 0: the rows are constraints (CSQP), > 0: the weight of their
            exact quadratic penalty (Box-FDDP).
    """

    def __init__(self, prediction: PlantPrediction, state: crocoddyl.StateMultibody, costs: crocoddyl.CostModelSum,
                 lower: np.ndarray, upper: np.ndarray, constraints: NodeConstraints, penalty: float) -> None:
        ng = 0 if penalty > 0.0 else constraints.ng
        crocoddyl.DifferentialActionModelAbstract.__init__(self, state, prediction.nu, costs.nr, ng, 0, ng, 0)
        self.prediction, self.costs, self.constraints, self.penalty = prediction, costs, constraints, penalty
        self.nq, self.nv = state.nq, state.nv
        self.u_lb, self.u_ub = lower, upper
        if ng:
            self.g_lb, self.g_ub = constraints.lower, constraints.upper

    def calc(self, data: PlantActionData, x: np.ndarray, u: np.ndarray | None = None) -> None:
        data.rejected = not (np.abs(x).max() < UNBOUNDED and (u is None or np.abs(u).max() < UNBOUNDED))
        if data.rejected:
            self._reject(data, u)
            return
        q, v = x[:self.nq], x[self.nq:]
        if u is None:  # the terminal node: its costs only
            pin.framesForwardKinematics(self.state.pinocchio, data.pinocchio, q)
            self.costs.calc(data.costs, x)
        else:
            try:
                dynamics = self.prediction.evaluate(q, v, u)
            except NumericalError:  # a trial point where the vehicle's block does not solve: as a non-finite one
                data.rejected = True
                self._reject(data, u)
                return
            data.acceleration, data.mass = dynamics.acceleration, dynamics.mass_matrix
            data.xout[:] = data.acceleration
            pin.framesForwardKinematics(self.state.pinocchio, data.pinocchio, q)
            self.costs.calc(data.costs, x, u)
        data.cost = data.costs.cost
        constraints = self.constraints
        if constraints.objectives:  # the rows and their Jacobian at once (one distance query): calcDiff reads them
            data.rows, data.rows_jacobian = constraints.state_rows(data.configuration, q)
        if self.penalty > 0.0:
            if constraints.objectives:
                data.cost += constraints.penalty(data.rows, data.rows_jacobian, self.penalty)[0]
        elif constraints.ng:  # a running node evaluated without its input (Crocoddyl may) keeps its input rows
            if u is not None:
                data.g[:constraints.nu] = u[:constraints.nu]
            data.g[constraints.nu:] = data.rows
        if not (data.cost < REJECTED_COST and np.isfinite(data.xout).all()):  # a NaN cost fails the comparison
            data.rejected = True
            self._reject(data, u)

    def _reject(self, data: PlantActionData, u: np.ndarray | None) -> None:
        """The node at a point out of range: REJECTED_COST, every row violated by UNBOUNDED, no acceleration."""
        data.cost = REJECTED_COST
        if u is not None:
            data.xout[:] = 0.0
        if self.ng:
            data.g[:] = self.g_ub + UNBOUNDED

    def calcDiff(self, data: PlantActionData, x: np.ndarray, u: np.ndarray | None = None) -> None:  # noqa: N802
        if data.rejected:  # no derivatives out of range: a flat node (its inputs' rows kept)
            for array in (data.Fx, data.Fu, data.Lx, data.Lu, data.Lxx, data.Lxu, data.Luu, data.Gx, data.Gu):
                array[:] = 0.0
            if u is not None and self.constraints.nu:
                data.Gu[:self.constraints.nu] = np.eye(self.constraints.nu)
            return
        q, v = x[:self.nq], x[self.nq:]
        pin.computeJointJacobians(self.state.pinocchio, data.pinocchio, q)
        if u is None:
            self.costs.calcDiff(data.costs, x)
        else:
            da_dq, da_dv, da_du = self.prediction.derivatives(q, v, u, data.acceleration, data.mass,
                                                              out=data.derivatives)
            data.Fx[:, :self.nv] = da_dq
            data.Fx[:, self.nv:] = da_dv
            data.Fu[:] = da_du
            self.costs.calcDiff(data.costs, x, u)
        constraints, nv = self.constraints, self.nv
        if self.penalty > 0.0:
            if constraints.objectives:
                _, gradient, hessian = constraints.penalty(data.rows, data.rows_jacobian, self.penalty)
                data.Lx[:nv] += gradient
                data.Lxx[:nv, :nv] += hessian
        elif constraints.ng:
            rows = constraints.nu
            if rows and u is not None:
                data.Gu[:rows] = np.eye(rows)
            data.Gx[rows:, :nv] = data.rows_jacobian

    def createData(self) -> PlantActionData:  # noqa: N802
        return PlantActionData(self)


class NodeCosts:
    """The costs of one node and the handles that move their references (the trajectory, the station)."""

    def __init__(self, state: crocoddyl.StateMultibody, nu: int, settings: MPCSettings, frame: int,
                 x_station: np.ndarray, n_thrusters: int, *, terminal: bool) -> None:
        nv, s = state.nv, settings
        nb = 6  # the free-flyer's velocity coordinates
        self.sum = crocoddyl.CostModelSum(state, nu)
        self.target = crocoddyl.ResidualModelFrameTranslation(state, frame, np.zeros(3), nu)
        self.task_weight = s.terminal_end_effector if terminal else s.end_effector
        self.sum.addCost("end_effector", crocoddyl.CostModelResidual(state, self.target), self.task_weight)
        self.end_effector = self.sum.costs["end_effector"]
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

    def weigh_task(self, share: float) -> None:
        """The end effector's weight at ``share`` (0, 1] of the settings' (the task giving way to the constraints)."""
        self.end_effector.weight = share * self.task_weight

    def move(self, target: np.ndarray, x_station: np.ndarray | None = None) -> None:
        """Set the end effector's target (3,) [m], and the station (nx,) when given."""
        self.target.reference = target
        if x_station is not None:
            self.station.reference = x_station


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
