"""The whole-body MPC controller: each control step, CSQP (or Box-FDDP) on the plant's model from the measured state.

It is a :class:`uvms.control.base.Controller`: ``reset(state, t)`` and ``command(state, t)`` -> a
:class:`~uvms.dynamics.plant.command.Command` with the thrusts [N] and the arm's velocity commands, what an
:class:`~uvms.dynamics.plant.actuated.ActuatedPlant` applies. Every control_period it sets the
problem's initial state to the measurement and the nodes' targets to the trajectory over the horizon, shifts the
previous solution by the time gone (the warm start) and runs a few solver iterations; the first node's input is
applied and held until the next solve. The scenario's inequality objectives are the problem's constraints
(:mod:`uvms.control.mpc.constraints`).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence

import numpy as np
import pinocchio as pin

from ...dynamics.plant.command import Command, State
from ...dynamics.plant.plant import Plant
from ...dynamics.thrusters.thrusters import Thrusters, allocation_matrix
from ...errors import UVMSError
from ...tasks.objectives.base import Inequality
from .optional import require_crocoddyl
from .prediction import PlantPrediction
from .settings import MPCSettings


def prediction_plant(plant: Plant, knows_current: bool) -> Plant:
    """The plant the MPC predicts with: ``plant`` itself when the current is known, else the same in still water."""
    if knows_current or not np.any(plant.hydro.current):
        return plant
    return Plant(plant.robot, plant.hydro.with_current(np.zeros(3)), gravity=plant.gravity,
                 motor_time_constant=plant.motor_time_constant, added_mass=plant.added_mass, damping=plant.damping)


def make_solver(problem: object, settings: MPCSettings) -> object:
    """The solver of ``problem``: mim-solvers' CSQP (its QP to ``qp_iterations``, no printing) or Box-FDDP."""
    if settings.solver == "box_fddp":
        return require_crocoddyl().SolverBoxFDDP(problem)
    from .optional import require_mim_solvers

    solver = require_mim_solvers().SolverCSQP(problem)
    solver.max_qp_iters = settings.qp_iterations
    solver.with_callbacks = False
    solver.termination_tolerance = 1e-4
    return solver


class MPCController:
    """Whole-body model-predictive control of the vehicle (its thrusters) and the arm (its joint servos).

    Args:
        plant: the plant the controller acts on (its model, hydrodynamics, gravity, servos: the prediction's;
            its current only when ``settings.knows_current``).
        thrusters: the vehicle's thrusters (their allocation geometry and thrust bounds).
        target: t [s] -> the end effector's position (3,) [m], world frame.
        frame: the end-effector frame (None: the robot's first).
        settings: horizon, node step, solver, iterations, weights (:class:`uvms.control.mpc.settings.MPCSettings`).
        constraints: the scenario's inequality objectives (``ScenarioInequalities.objectives``: joint limits, tilt,
            clearance, obstacles, self-collision), built on ``plant.robot``: kept at every node after the first.

    Raises:
        UVMSError: Crocoddyl not installed (the ``mpc`` extra), a vehicle that is not floating, no thrusters.
    """

    def __init__(self, plant: Plant, thrusters: Thrusters, target: Callable[[float], np.ndarray], *,
                 frame: str | None = None, settings: MPCSettings | None = None,
                 constraints: Sequence[Inequality] = ()) -> None:
        crocoddyl = require_crocoddyl()
        from .action import NodeCosts, PlantActionModel, input_bounds, integrated
        from .constraints import NodeConstraints

        robot = plant.robot
        if robot.base_type != "floating":
            raise UVMSError(f"the MPC needs a floating vehicle (6 degrees of freedom); {robot.name} has a "
                            f"{robot.base_type} base")
        if len(thrusters) == 0:
            raise UVMSError(f"{thrusters.source}: the MPC needs thrusters to move the vehicle")
        self.settings = settings = MPCSettings() if settings is None else settings
        self.robot, self.target, self.n = robot, target, len(thrusters)
        self.time_constants = thrusters.time_constants
        self.prediction = PlantPrediction(prediction_plant(plant, settings.knows_current),
                                          allocation_matrix(robot, thrusters))
        model = self.prediction.model
        self.state = crocoddyl.StateMultibody(model)
        frame_id = robot.frame_id(frame)
        self._frame_id, self._ee_data = frame_id, robot.model.createData()
        lower, upper = input_bounds(self.prediction, thrusters.lower, thrusters.upper)
        x_rest = np.concatenate([pin.neutral(model), np.zeros(model.nv)])
        constrained = settings.solver == "csqp"
        penalty = 0.0 if constrained else settings.penalty
        self.constraints = list(constraints)
        self.nodes, running = [], []
        for index in range(settings.horizon + 1):
            terminal = index == settings.horizon
            costs = NodeCosts(self.state, self.prediction.nu, settings, frame_id, x_rest, self.n, terminal=terminal)
            rows = NodeConstraints(robot, self.constraints, None if terminal or not constrained else lower,
                                   None if terminal or not constrained else upper, with_state=index > 0,
                                   margin=settings.collision_margin,
                                   scale=settings.constraint_scale if constrained else 1.0)
            action = PlantActionModel(self.prediction, self.state, costs.sum, lower, upper, rows, penalty)
            self.nodes.append((costs, action))
            running.append(integrated(action, 0.0 if terminal else settings.node_dt, settings.integrator))
        self.problem = crocoddyl.ShootingProblem(x_rest, running[:-1], running[-1])
        self.solver = make_solver(self.problem, settings)
        self._rows_at = self.nodes[-1][1].constraints  # the objectives' rows at the measured state (relaxation)
        self._measured = self._rows_at.configuration()
        self.lower, self.upper = lower, upper
        self.solve_times: list[float] = []  # [s] per solve
        self.iterations: list[int] = []
        self._held: Command | None = None
        self._solved_at: float | None = None
        self._last: tuple | None = None  # (q, v, t, thrusts) at the last solve: the estimate's
        self._estimated = False
        self._xs: list[np.ndarray] = []
        self._us: list[np.ndarray] = []
        self._allocation_inverse = np.linalg.pinv(self.prediction.matrix)  # (n, 6): wrench -> min-norm thrusts
        self.rejected = 0  # solves whose line search accepted no step (the last plan applied)
        self.saturation = 0.0  # the largest share of their range that holding still asked of the thrusters

    def metrics(self) -> dict:
        """``metrics.json``'s ``"mpc"`` entry: solves, solve time per control step [s] (median, p99, max) and the
        solver's iterations (mean, max)."""
        times, iterations = np.asarray(self.solve_times, dtype=float), np.asarray(self.iterations, dtype=float)
        settings = self.settings
        entry = {"solves": int(times.size), "solver": settings.solver, "horizon": float(settings.duration),
                 "nodes": int(settings.horizon), "control_period": float(settings.control_period),
                 "rejected_steps": int(self.rejected), "max_thrust_saturation": float(self.saturation)}
        if times.size:
            entry.update(solve_time_median=float(np.median(times)), solve_time_p99=float(np.percentile(times, 99)),
                         solve_time_max=float(times.max()), iterations_mean=float(iterations.mean()),
                         iterations_max=int(iterations.max()))
        return entry

    @property
    def horizon(self) -> float:
        """The prediction horizon [s]."""
        return self.settings.duration

    def reset(self, state: State, t: float = 0.0) -> None:
        """Start from the state (q (nq,), v (nv,); None: rest) at t [s]: the station is the vehicle's pose and the
        arm's joints there; the first guess holds the state with zero input."""
        q = self.robot.check_configuration(state.q)
        v = np.zeros(self.robot.model.nv) if state.v is None else self.robot.check_velocity(state.v)
        station = np.concatenate([q, np.zeros(self.robot.model.nv)])
        for costs, _ in self.nodes:
            costs.move(np.zeros(3), station)
        x0 = np.concatenate([q, v])
        self._xs = [x0.copy() for _ in range(self.settings.horizon + 1)]
        self._us = [np.clip(np.zeros(self.prediction.nu), self.lower, self.upper)
                    for _ in range(self.settings.horizon)]
        self._held, self._solved_at, self._last = None, None, None
        self._estimated = False
        self.prediction.disturbance = np.zeros(6)
        self.solve_times.clear()
        self.iterations.clear()
        self.rejected, self.saturation = 0, 0.0

    def command(self, state: State, t: float) -> Command:
        """The thrusts (n,) [N] and arm velocity commands (n_arm,) for the measured state (q, v, thrusts) at t [s].

        Solves when a control period has passed since the last solve (or at the first call), else holds. With the
        measured thrusts (n,) [N] and ``settings.lag_compensation``, the thrust command is the one whose
        first-order response from the measured thrust f has the planned thrust as its mean over the control period h
        (what the prediction applies over a node: the lag it leaves out),
        f_cmd = f + (f_plan - f) / (1 - tau/h (1 - e^(-h/tau))), clipped to the bounds. (Aiming at f_plan at the end
        of the period instead gives about half the impulse in a period that starts from rest: the intervention's
        max end-effector error 0.66 cm against 0.30 cm.)
        """
        q, v, thrusts = state.q, state.v, state.thrusts
        if not self._xs:
            self.reset(state, t)
        period = self.settings.control_period
        if self._held is not None and t < self._solved_at + period - 1e-9:
            return self._held
        if thrusts is not None:
            self._estimate(q, v, float(t), np.asarray(thrusts, dtype=float))
        self._held = self._solve(np.concatenate([q, v]), float(t))
        if thrusts is not None and self.settings.lag_compensation and period > 0.0:
            measured = np.asarray(thrusts, dtype=float)
            share = 1.0 - self.time_constants / period * (1.0 - np.exp(-period / self.time_constants))
            thrust = np.clip(measured + (self._held.thrust - measured) / share, self.lower[:self.n],
                             self.upper[:self.n])
            self._held = Command(arm=self._held.arm, thrust=thrust, info=self._held.info)
        return self._held

    def _estimate(self, q: np.ndarray, v: np.ndarray, t: float, thrusts: np.ndarray) -> None:
        """Update the estimated wrench on the vehicle from the last period's mismatch (measured - predicted vehicle
        acceleration, the thrusts the mean of the measured ones), low-pass filtered."""
        last, self._last = self._last, (q.copy(), v.copy(), t, thrusts.copy())
        constant = self.settings.disturbance_time_constant
        if last is None or constant <= 0.0 or self._held is None or t <= last[2]:
            return
        q0, v0, t0, f0 = last
        prediction, nb = self.prediction, self.prediction.nb
        u = np.concatenate([0.5 * (f0 + thrusts), self._held.arm])
        dynamics = prediction.evaluate(q0, v0, u)
        # the predicted acceleration averaged over the period's ends (the drag changes fast as the current sets the
        # vehicle moving; taken at the start alone, a 1.0 m/s current's first estimate was 42 N off)
        predicted = 0.5 * (dynamics.acceleration[:nb] + prediction.evaluate(q, v, u).acceleration[:nb])
        mismatch = (v[:nb] - v0[:nb]) / (t - t0) - predicted
        # the first mismatch is taken whole (there is no estimate to filter it against: the current acts from the
        # start, and a filtered first estimate lets the vehicle drift for several periods)
        gain = 1.0 - np.exp(-(t - t0) / constant) if self._estimated else 1.0
        self._estimated = True
        prediction.disturbance = prediction.disturbance + gain * prediction.wrench_of(
            dynamics.mass_matrix[:nb, :nb] @ mismatch)

    def _relax(self, x0: np.ndarray) -> None:
        """The nodes' bounds from the measured state's rows (:meth:`NodeConstraints.relaxed`)."""
        start, _ = self._rows_at.state_rows(self._measured, x0[:self.robot.model.nq])
        recovery = self.settings.recovery_nodes
        for index, (_, action) in enumerate(self.nodes[1:], start=1):
            action.g_lb, action.g_ub = action.constraints.relaxed(start, min(1.0, index / recovery))

    def _targets(self, x0: np.ndarray, t: float) -> list[np.ndarray]:
        """The nodes' end-effector targets (3,) [m]: the trajectory's, within ``settings.end_effector_reach`` of
        the measured end effector (x0's)."""
        settings = self.settings
        targets = [np.asarray(self.target(t + index * settings.node_dt), dtype=float)
                   for index in range(settings.horizon + 1)]
        reach = settings.end_effector_reach
        if reach <= 0.0:
            return targets
        pin.framesForwardKinematics(self.robot.model, self._ee_data, x0[:self.robot.model.nq])
        here = self._ee_data.oMf[self._frame_id].translation.copy()
        for index, target in enumerate(targets):
            distance = float(np.linalg.norm(target - here))
            if distance > reach:
                targets[index] = here + (target - here) * (reach / distance)
        return targets

    def _warm_start(self, t: float) -> tuple[list[np.ndarray], list[np.ndarray]]:
        """The last plan read at the nodes' times from t [s] on (the warm start): states along the manifold and
        inputs linearly between its nodes, the last node held beyond it.

        The plan's node k was at solved_at + k node_dt; a control period that is not a whole number of nodes
        (20 Hz with 0.1 s nodes) would otherwise shift by round(0.5), which floating point makes 0 or 1 from one
        solve to the next: half of the warm starts then sat a whole node off their time, and CSQP's line search cut
        their step in half (the saturated current: tilt 0.278 rad with the shift, 0.164 rad read in time)."""
        if self._solved_at is None:
            return list(self._xs), list(self._us)
        last, state = self.settings.horizon, self.state
        ratio = max(0.0, (t - self._solved_at) / self.settings.node_dt)
        xs, us = [], []
        for index in range(last + 1):
            position = min(index + ratio, float(last))
            node = min(int(position + 1e-9), last)
            share = position - node
            if node == last or share <= 1e-9:
                xs.append(self._xs[node].copy())
            else:
                xs.append(state.integrate(self._xs[node], share * state.diff(self._xs[node], self._xs[node + 1])))
            if index < last:
                node = min(node, last - 1)
                share = 0.0 if node + 1 >= last else min(max(position - node, 0.0), 1.0)
                us.append((1.0 - share) * self._us[node] + share * self._us[node + 1] if share > 1e-9
                          else self._us[node].copy())
        return xs, us

    def _task_share(self, x0: np.ndarray) -> float:
        """The task's weight share (0, 1] from the thrust that holding the vehicle still at the measured pose asks
        (against the prediction's current, restoring wrench and estimated disturbance; the minimum-norm
        allocation): 1 up to ``saturation_onset`` of the thrusters' range, ``saturated_task_share`` from the whole
        range on, geometrically between (the constraints first: a task out of the thrusters' reach gives way)."""
        settings, prediction = self.settings, self.prediction
        if settings.saturated_task_share >= 1.0:
            return 1.0
        q, nb = x0[:self.robot.model.nq], prediction.nb
        still = prediction.evaluate(q, np.zeros(prediction.nv), np.zeros(prediction.nu))
        wrench = prediction.wrench_of(still.mass_matrix[:nb, :nb] @ still.acceleration[:nb])
        holding = -self._allocation_inverse @ wrench  # (n,) [N]
        bound = np.where(holding >= 0.0, self.upper[:self.n], -self.lower[:self.n])
        ratio = float(np.max(np.abs(holding) / bound))
        self.saturation = max(self.saturation, ratio)
        onset = settings.saturation_onset
        if ratio <= onset:
            return 1.0
        return float(settings.saturated_task_share ** min(1.0, (ratio - onset) / max(1.0 - onset, 1e-9)))

    def _solve(self, x0: np.ndarray, t: float) -> Command:
        settings = self.settings
        xs, us = self._warm_start(t)
        xs[0] = x0
        share = self._task_share(x0)
        for costs, _ in self.nodes:
            costs.weigh_task(share)
        for costs, target in zip((costs for costs, _ in self.nodes), self._targets(x0, t)):
            costs.move(target)
        self.problem.x0 = x0
        started = time.perf_counter()
        if settings.solver == "csqp" and self.constraints:
            self._relax(x0)
        self.solver.solve(xs, us, settings.iterations, False)
        elapsed = time.perf_counter() - started
        # copies: CSQP's xs and us are views into a temporary list, garbage once it is gone. A solve whose line
        # search accepted no step (iter 0) leaves them at the warm start: the last plan read in time is applied.
        self._xs, self._us = [x.copy() for x in self.solver.xs], [u.copy() for u in self.solver.us]
        if not all(np.isfinite(x).all() for x in self._xs) or not all(np.isfinite(u).all() for u in self._us):
            self._xs, self._us = xs, us  # a step into non-finite values (from a non-finite warm start): none
        self.rejected += int(self.solver.iter) == 0 or self._xs is xs
        if not all(np.all(np.isfinite(u)) for u in self._us[:1]):
            raise UVMSError(f"the MPC's solution is not finite at t = {t:.6g} s; lower its weights or node_dt")
        self.solve_times.append(elapsed)
        self.iterations.append(int(self.solver.iter))
        self._solved_at = t
        first = np.clip(self._us[0], self.lower, self.upper)
        thrust, arm = self.prediction.split(first)
        return Command(arm=arm.copy(), thrust=thrust.copy(), info={
            "mpc_solve_time": elapsed, "mpc_iterations": float(self.solver.iter), "mpc_cost": float(self.solver.cost)})
