"""The QP hierarchy: the levels of the set-based solver as a cascade of QPs with slacks, never infeasible.

Level k (highest first) solves, over the solved velocity x (n,) and its slacks w (m_k,):

    minimize    1/2 |E_k x - r_k|^2 + 1/2 |w|^2 + 1/2 (rho + lambda_k^2) |x|^2_W
    subject to  G_k x + w >= b_k,  w >= 0                    its inequality objectives, relaxed by w
                the rows of every level above at their optimum (equality rows at J x*, inequality rows
                with their optimal slack), up to a tolerance
                lower <= v <= upper                            the hard bounds

with E_k, r_k the equality tasks' rows and commands (xdot_d + K e) and G_k x >= b_k the valid sets of
the inequality objectives as velocity dampers (:meth:`~uvms.tasks.objectives.InequalityRows.constraint`).
lambda_k is the damping of CLIK and the set-based solver (fixed, or amundsen2018 eq. 6 variable) read from
sigma_min of E_k W^-1/2 with each joint's column times 1 - its joint-limit activation: the columns the
joint-limit bounds hold taken out, as the set-based levels take them out. Without it (rho alone, 1e-9) a
task that the held joints leave short reaches for any column that still moves it, however little, and
drives it to its speed limit: in ``bluerov2_alpha5_free_floating_limit`` the wrist roll, which moves the
tool point only through the vehicle's momentum, switched between -0.5 and +0.5 rad/s (per-step jumps of
1 rad/s); with the scenario's variable damping it stays below 0.01 rad/s.
The hard bounds are the speed limits and the joint-limit objectives' valid sets turned into rate bounds
over one step, clipped into the speed limits (:func:`~uvms.solvers.saturation.velocity_box`), so the box
is never empty and a joint started outside its valid set comes back at the allowed speed. A free-floating
vehicle's speed limits are rows of the arm velocity (v_b = T_b qdot_arm); they get a slacked level of
their own above the others. Every level is feasible (its slacks absorb its inequalities, and the solution
of the level above meets the rest); a level whose QP fails keeps that solution and says so in
``solver_status``. The QPs go to DAQP (its own API), else ProxQP through qpsolvers (:mod:`uvms.solvers.cascade`).

This is the optimization family of pink/mink with strict priorities (Kanoun et al. 2011, Escande et al.
2014 style), here on the same levels as :class:`~uvms.solvers.set_based.SetBasedSolver`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..numerics.checks import check_damping, check_scalar, check_weights
from ..numerics.inverses import SolverInputError, VariableDamping, smallest_singular_value, weights_factor
from ..robot.configuration import Configuration
from ..robot.robot import Robot
from ..tasks.objectives import VelocityLimit
from .base import Solver
from .cascade import PREFERRED_SOLVERS, Cascade, installed_solvers, level_attempts, qp_solver, solve_level
from .hierarchy import Hierarchy, HierarchyPlan, LevelRows, Levels, solved_rows, speed_ratio
from .item_rows import ItemRows
from .result import SolverResult
from .saturation import RateRows, speed_maximum, velocity_box

#: Tolerance within which a constraint row counts as binding.
BINDING_TOLERANCE = 1e-7


def level_constraints(hierarchy: Hierarchy, level: LevelRows) -> tuple[np.ndarray, np.ndarray, list[tuple[str, slice]]]:
    """The level's inequality rows G x >= b (solved columns) and each objective's rows (joint limits: bounds)."""
    blocks, bounds, spans, start = [], [], [], 0
    for objective, rows in zip(level.inequalities, level.objectives):
        if objective.bounds_joint_positions:
            continue
        matrix, bound = rows.constraint()
        solved = hierarchy.state.generalized(matrix) if hierarchy.free_floating else matrix
        blocks.append(solved)
        bounds.append(bound)
        spans.append((rows.name, slice(start, start + bound.size)))
        start += bound.size
    if not blocks:
        return np.zeros((0, hierarchy.size)), np.zeros(0), spans
    return np.vstack(blocks), np.concatenate(bounds), spans


def vehicle_speed_rows(hierarchy: Hierarchy, lower: np.ndarray,
                       upper: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Free floating: the vehicle's speed box as rows G x >= b of the arm velocity (finite bounds only)."""
    if not hierarchy.free_floating:
        return np.zeros((0, hierarchy.size)), np.zeros(0)
    n_vehicle = hierarchy.vehicle_map.shape[0]
    low, high = lower[:n_vehicle], upper[:n_vehicle]
    finite_low, finite_high = np.isfinite(low), np.isfinite(high)
    rows = np.vstack([hierarchy.vehicle_map[finite_low], -hierarchy.vehicle_map[finite_high]])
    return rows, np.concatenate([low[finite_low], -high[finite_high]])


class HQPSolver(Solver):
    """The QP hierarchy over the levels of :class:`~uvms.solvers.set_based.SetBasedSolver` (scenario method "hqp"),
    its inputs checked, its levels split and its QP solver chosen once.

    Args:
        robot: the model.
        levels: highest priority first; each level a Task, an Inequality, or a list of them (speed limits
            anywhere). Joint-limit objectives are hard bounds; the other inequalities are slacked rows of
            their level.
        dt: step [s] > 0 over which position limits become rate bounds.
        gain: K of the equality tasks [1/s].
        weights: W of the solved columns (n,) or (n, n), used by the regularization and the damping.
        damping: lambda >= 0 or a VariableDamping of the levels' task rows, as in CLIK (module docstring).
        free_floating: solve the arm only, the vehicle passive (generalized Jacobians).
        position_fraction: the part of the distance to a limit one step may cover, in (0, 1].
        regularization: rho >= 0, weight of ``|x|^2_W`` in every level (a unique solution) [-].
        solver: a qpsolvers solver name; default DAQP, then ProxQP (the other tried when one fails).
        speed_limits: more speed limits (besides those in the levels).

    Raises:
        SolverInputError: malformed levels, a bad dt, gain, weight, damping, position_fraction or regularization, a QP
            solver not installed, free_floating on a fixed base.
    """

    name = "hqp"
    enforces_inequalities = True
    shares_rows = True

    def __init__(
        self,
        robot: Robot,
        levels: Levels,
        *,
        dt: float,
        gain: float | np.ndarray = 1.0,
        weights: np.ndarray | None = None,
        damping: float | VariableDamping = 0.0,
        free_floating: bool = False,
        position_fraction: float = 1.0,
        regularization: float = 1e-9,
        solver: str | None = None,
        speed_limits: Sequence[VelocityLimit] = (),
    ) -> None:
        self.plan = HierarchyPlan(robot, levels, gain, free_floating, speed_limits)
        self.robot, self.free_floating = robot, free_floating
        self.dt = check_scalar(dt, "dt", positive=True)
        self.fraction = check_scalar(position_fraction, "position_fraction", positive=True)
        if self.fraction > 1:
            raise SolverInputError(f"position_fraction must be in (0, 1], got {position_fraction!r}")
        self.regularization = check_scalar(regularization, "regularization")
        self.solver = qp_solver(solver)
        self._solvers = [self.solver] + [name for name in PREFERRED_SOLVERS
                                         if name != self.solver and name in installed_solvers()]
        self._attempts = level_attempts(self._solvers)  # (solver, options, keep tolerance) in the order tried
        self._weights = _weight_matrix(weights, self.plan.size)
        if weights is not None:
            weights_factor(weights, self.plan.size)  # W positive definite (SolverInputError otherwise)
        self.damping = damping if isinstance(damping, VariableDamping) else check_damping(damping)
        variable = isinstance(self.damping, VariableDamping)  # W^-1/2 = L^-T (W = L L^T): what its sigma_min reads
        self._inverse_root = np.linalg.inv(np.linalg.cholesky(self._weights)).T if variable else None
        self.maximum = speed_maximum(robot.nv, self.plan.speed_limits)  # (nv,)
        self._rate_rows = RateRows.of(self.plan.joint_limits, valid_set=True)  # the valid sets' rows, stacked once
        self._unbounded = np.full(robot.nv, -np.inf), np.full(robot.nv, np.inf)

    def velocity(self, configuration: Configuration, shared: ItemRows | None = None) -> SolverResult:
        """The velocity of the QP hierarchy at ``configuration``: the objectives active when a constraint binds
        or is relaxed; ``extras`` has ``solver_status`` and ``slacks`` per level and the ``solver`` used;
        ``shared``: the items' rows already evaluated at ``configuration`` (:meth:`HierarchyPlan.evaluate`)."""
        hierarchy = self.plan.evaluate(self._checked(configuration), shared)
        maximum = self.maximum
        rate_lower, rate_upper = (self._rate_rows.bounds(hierarchy.state.q, self.robot.nv, self.dt, self.fraction)
                                  if self.plan.joint_limits else self._unbounded)
        lower, upper = velocity_box(maximum, rate_lower, rate_upper)
        cascade = initial_cascade(hierarchy, lower, upper)

        freedom = joint_freedom(hierarchy) if isinstance(self.damping, VariableDamping) else None
        used = 0.0

        def solve(equality, command, inequality, bound):
            nonlocal used
            damping = level_damping(equality, freedom, self._inverse_root, self.damping)
            used = max(used, damping)
            return solve_level(cascade, equality, command, inequality, bound, self._weights,
                               self.regularization + damping**2, self._attempts)

        vehicle_rows, vehicle_bounds = vehicle_speed_rows(hierarchy, lower, upper)
        if vehicle_bounds.size:  # a slacked level of its own, above the others
            cascade.x, slack, _ = solve(np.zeros((0, hierarchy.size)), np.zeros(0), vehicle_rows, vehicle_bounds)
            cascade.keep_inequalities(vehicle_rows, vehicle_bounds, slack)
        statuses, slacks, solved = [], [], []
        for level in hierarchy.levels:
            equality, command = level_equalities(hierarchy, level)
            inequality, bound, spans = level_constraints(hierarchy, level)
            cascade.x, slack, status = solve(equality, command, inequality, bound)
            cascade.keep_equalities(equality)
            cascade.keep_inequalities(inequality, bound, slack)
            statuses.append(status)
            slacks.append(float(np.linalg.norm(slack)))
            solved.append((inequality, bound, slack, spans))
        v = hierarchy.velocity(cascade.x)
        x = cascade.x

        def binding() -> dict[str, bool]:  # read at the final x: the levels below are what push a row onto its bound
            found = {}
            for inequality, bound, slack, spans in solved:
                found.update(inequalities_binding(inequality @ x - (bound - slack), slack, spans))
            found.update(joint_limits_binding(hierarchy, v, rate_lower, rate_upper, maximum))
            return found

        return SolverResult(v=v, sigma_min=lambda: task_sigma_min(hierarchy), damping=used,
                            free_floating=self.free_floating, scales=(1.0,) * len(hierarchy.levels),
                            speed_ratio=speed_ratio(v, maximum),
                            extras={"solver_status": tuple(statuses), "slacks": tuple(slacks), "solver": self.solver},
                            levels=solved_rows(hierarchy), binding=binding)


def initial_cascade(hierarchy: Hierarchy, lower: np.ndarray, upper: np.ndarray) -> Cascade:
    """The cascade before any level: the box on the solved columns, x = 0 clipped into it."""
    robot = hierarchy.state.robot
    solved = slice(robot.n_vehicle, robot.nv) if hierarchy.free_floating else slice(0, robot.nv)
    low, high = lower[solved], upper[solved]
    return Cascade(size=hierarchy.size, lower=low, upper=high, x=np.clip(np.zeros(hierarchy.size), low, high))


def joint_freedom(hierarchy: Hierarchy) -> np.ndarray:
    """Per solved column (n,), 1 - the largest joint-limit activation on it (1: free, 0: held at a limit)."""
    freedom = np.ones(hierarchy.size)
    offset = hierarchy.state.robot.n_vehicle if hierarchy.free_floating else 0
    for level in hierarchy.levels:
        for objective, rows in zip(level.inequalities, level.objectives):
            if objective.bounds_joint_positions:
                index = objective.v_index - offset
                freedom[index] = np.minimum(freedom[index], 1.0 - rows.activation)
    return freedom


def level_damping(equality: np.ndarray, freedom: np.ndarray | None, inverse_root: np.ndarray | None,
                  damping: float | VariableDamping) -> float:
    """lambda of a level with task rows E (k, n): fixed, or amundsen2018 eq. 6 of sigma_min of
    E diag(freedom) W^-1/2 (the columns the joint limits hold taken out; ``freedom`` and ``inverse_root`` = W^-1/2
    read only by a variable damping); 0 without task rows."""
    if not equality.size:
        return 0.0
    if not isinstance(damping, VariableDamping):
        return damping
    return damping(smallest_singular_value((equality * freedom) @ inverse_root))


def level_equalities(hierarchy: Hierarchy, level: LevelRows) -> tuple[np.ndarray, np.ndarray]:
    """The level's equality-task rows E (k, n) (solved columns) and commands r (k,) (0 rows without tasks)."""
    if not level.has_tasks:
        return np.zeros((0, hierarchy.size)), np.zeros(0)
    return level.solved[: level.task_error.size], level.task_command


def inequalities_binding(margin: np.ndarray, slack: np.ndarray, spans: list[tuple[str, slice]]) -> dict[str, bool]:
    """Per objective: some row binding (``margin`` G x - (b - w*) ~ 0 at the final x, w* its slack) or relaxed
    (w* > 0)."""
    return {name: bool(np.any(margin[span] <= BINDING_TOLERANCE) or np.any(slack[span] > BINDING_TOLERANCE))
            for name, span in spans}


def task_sigma_min(hierarchy: Hierarchy) -> float:
    """sigma_min of the last level's equality-task rows (solved columns; 0 without tasks)."""
    task_levels = [level for level in hierarchy.levels if level.has_tasks]
    return smallest_singular_value(level_equalities(hierarchy, task_levels[-1])[0]) if task_levels else 0.0


def joint_limits_binding(hierarchy: Hierarchy, v: np.ndarray, rate_lower: np.ndarray, rate_upper: np.ndarray,
                         maximum: np.ndarray) -> dict[str, bool]:
    """Per joint-limit objective: some joint's velocity sits on a rate bound tighter than its speed limit."""
    result = {}
    for objective in hierarchy.joint_limits:
        index = objective.v_index
        low = (rate_lower[index] > -maximum[index]) & (v[index] <= rate_lower[index] + BINDING_TOLERANCE)
        high = (rate_upper[index] < maximum[index]) & (v[index] >= rate_upper[index] - BINDING_TOLERANCE)
        result[objective.name] = bool(np.any(low | high))
    return result


def _weight_matrix(weights: np.ndarray | None, size: int) -> np.ndarray:
    if weights is None:
        return np.eye(size)
    weights = check_weights(weights, size)
    return np.diag(weights) if weights.ndim == 1 else weights
