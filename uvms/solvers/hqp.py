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
``solver_status``. The QPs go through qpsolvers (DAQP, else ProxQP).

This is the optimization family of pink/mink with strict priorities (Kanoun et al. 2011, Escande et al.
2014 style), here on the same levels as :class:`~uvms.solvers.set_based.SetBasedSolver`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..robot.robot import Robot
from ..robot.configuration import Configuration
from ..tasks.objectives import JointLimits, VelocityLimit
from ..numerics.checks import check_damping, check_scalar, check_weights
from ..numerics.inverses import SolverInputError, VariableDamping, smallest_singular_value
from .base import Solver
from .hierarchy import Hierarchy, HierarchyPlan, LevelRows, Levels, solved_rows, speed_ratio
from .result import SolverResult
from .saturation import RateRows, speed_maximum, velocity_box

#: QP solvers tried, in order, when none is named.
PREFERRED_SOLVERS = ("daqp", "proxqp")
#: Retries of a solver whose QP failed: DAQP with proximal-point iterations copes with the degenerate
#: feasible sets a cascade produces (a level pinned to a vertex of the box by the optimum above).
RETRY_OPTIONS = {"daqp": {"eps_prox": 1e-6}}
#: Looser keep tolerances tried when a level's QP fails at KEEP_TOLERANCE.
LOOSER_KEEP_TOLERANCES = (1e-6, 1e-4)
#: Tolerance [same units as the rows] with which the rows of the levels above are kept at their optimum.
KEEP_TOLERANCE = 1e-9
#: Tolerance within which a constraint row counts as binding.
BINDING_TOLERANCE = 1e-7


@dataclass
class Cascade:
    """The rows G x <= h that keep the levels solved at their optimum, and the current solution x (n,)."""

    size: int
    lower: np.ndarray
    upper: np.ndarray
    x: np.ndarray
    rows: list[np.ndarray] = field(default_factory=list)
    bounds: list[np.ndarray] = field(default_factory=list)

    def keep_equalities(self, jacobian: np.ndarray) -> None:
        """Keep J x at its value J x*."""
        achieved = jacobian @ self.x
        self.rows += [jacobian, -jacobian]
        self.bounds += [achieved, -achieved]

    def keep_inequalities(self, rows: np.ndarray, bounds: np.ndarray, slacks: np.ndarray) -> None:
        """Keep G x >= b - w* (w* the optimal slacks), or G x* where the solver left x* a little short of it."""
        kept = np.minimum(bounds - slacks, rows @ self.x)  # x* itself stays feasible
        self.rows.append(-rows)
        self.bounds.append(-kept)

    def stacked(self) -> tuple[np.ndarray, np.ndarray]:
        """(G (k, n), h (k,)) of the rows kept so far, before their loosening."""
        if not self.rows:
            return np.zeros((0, self.size)), np.zeros(0)
        return np.vstack(self.rows), np.concatenate(self.bounds)


def qp_solver(name: str | None) -> str:
    """The QP solver to use: ``name`` if qpsolvers has it, else the first of PREFERRED_SOLVERS installed.

    Raises:
        SolverInputError: qpsolvers missing, or the solver named not installed (the message lists those that are).
    """
    try:
        import qpsolvers
    except ImportError:  # pragma: no cover - a declared dependency
        raise SolverInputError("the QP hierarchy needs qpsolvers and a QP solver: "
                               "pip install 'qpsolvers[daqp]'") from None
    available = list(qpsolvers.available_solvers)
    if name is None:
        for preferred in PREFERRED_SOLVERS:
            if preferred in available:
                return preferred
        raise SolverInputError(f"no QP solver for the hierarchy: install daqp or proxsuite (found {available})")
    if name not in available:
        raise SolverInputError(f"QP solver {name!r} is not installed; installed: {', '.join(available) or 'none'}")
    return name


def solve_qp(cost: np.ndarray, linear: np.ndarray, rows: np.ndarray, upper: np.ndarray, lower: np.ndarray,
             solver: str, options: dict | None = None) -> np.ndarray | None:
    """min 1/2 z^T P z + c^T z s.t. lower <= [z; rows z] <= upper (z (s,), the first s entries of the bounds its
    box, the rest the rows'; a row's lower -1e30: one-sided); None when not found.

    DAQP is called through its own API with these arrays (what qpsolvers' DAQP interface passes it, without its
    problem object and checks, which cost three times the solve at these sizes), every other solver through
    qpsolvers (a row's upper bound as G z <= h).
    """
    size = linear.size
    if solver == "daqp":
        import daqp  # its Python API (a compiled module), installed with qpsolvers[daqp]

        try:
            x, _, exitflag, _ = daqp.solve(cost, linear, rows, upper, lower, np.zeros(upper.size, dtype=np.intc),
                                           **(options or {}))
        except Exception:  # noqa: BLE001 - a solver's failure is reported as a status, never raised
            return None
        return x if exitflag > 0 and x is not None and np.isfinite(x).all() else None
    from qpsolvers import Problem, solve_problem

    problem = Problem(cost, linear, rows if rows.size else None, upper[size:] if rows.size else None, None, None,
                      lower[:size], upper[:size])
    try:
        solution = solve_problem(problem, solver=solver, **(options or {}))
    except Exception:  # noqa: BLE001 - a solver's failure is reported as a status, never raised
        return None
    if not solution.found or solution.x is None or not np.all(np.isfinite(solution.x)):
        return None
    return solution.x


def level_attempts(solvers: Sequence[str]) -> list[tuple[str, dict, float]]:
    """(solver, options, keep tolerance) in the order tried: the first solver as is, with its retry options,
    then with the levels above kept to 1e-6 and 1e-4 (a cascade can pin a level to a vertex of the box,
    a feasible set a solver may call empty), then the other solvers."""
    first = solvers[0]
    attempts = [(first, {}, KEEP_TOLERANCE)]
    if first in RETRY_OPTIONS:
        attempts.append((first, RETRY_OPTIONS[first], KEEP_TOLERANCE))
    attempts += [(first, RETRY_OPTIONS.get(first, {}), tolerance) for tolerance in LOOSER_KEEP_TOLERANCES]
    return attempts + [(solver, {}, KEEP_TOLERANCE) for solver in solvers[1:]]


def solve_level(cascade: Cascade, equality: np.ndarray, command: np.ndarray, inequality: np.ndarray,
                bound: np.ndarray, weights: np.ndarray, regularization: float,
                attempts: Sequence[tuple[str, dict, float]]) -> tuple[np.ndarray, np.ndarray, str]:
    """One level's QP over z = [x, w]: (x, w, status); if every attempt (:func:`level_attempts`) fails, the
    cascade's x is kept. ``regularization``: the weight rho + lambda^2 of |x|^2_W in this level. The QP's arrays
    are written by one compiled call (:func:`~uvms.numerics._kernels.qp.level_qp_into`)."""
    from ..numerics._kernels.qp import level_qp_into, loosened_bounds_into  # numba: loaded at the first solve

    n, m = cascade.size, inequality.shape[0]
    kept_rows, kept = cascade.stacked()
    total, count = n + m, kept.size + m
    cost, rows = np.zeros((total, total)), np.zeros((count, total))
    linear, upper, lower = np.empty(total), np.empty(total + count), np.empty(total + count)
    tolerance = attempts[0][2]
    level_qp_into(equality.T @ equality + regularization * weights, -equality.T @ command, kept_rows, kept,
                  tolerance, inequality, bound, cascade.lower, cascade.upper, cost, linear, rows, upper, lower)
    for index, (solver, options, keep) in enumerate(attempts):
        if keep != tolerance:
            loosened_bounds_into(kept, keep, total, upper)
            tolerance = keep
        z = solve_qp(cost, linear, rows, upper, lower, solver, options)
        if z is not None:  # x* clipped into the box the solver kept to its tolerance: exactly feasible below
            x = np.clip(z[:n], cascade.lower, cascade.upper)
            notes = [f"{key}={value}" for key, value in options.items()]
            notes += [f"levels above kept to {keep:g}"] if keep > KEEP_TOLERANCE else []
            how = f" ({solver}{', ' if notes else ''}{', '.join(notes)})" if index else ""
            return x, np.maximum(bound - inequality @ x, 0.0), f"optimal{how}"
    return cascade.x, np.maximum(bound - inequality @ cascade.x, 0.0), "failed: kept the solution of the levels above"


def level_constraints(hierarchy: Hierarchy, level: LevelRows) -> tuple[np.ndarray, np.ndarray, list[tuple[str, slice]]]:
    """The level's inequality rows G x >= b (solved columns) and each objective's rows (joint limits: bounds)."""
    blocks, bounds, spans, start = [], [], [], 0
    for objective, rows in zip(level.inequalities, level.objectives):
        if isinstance(objective, JointLimits):
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
                                         if name != self.solver and name in _installed()]
        self._attempts = level_attempts(self._solvers)  # (solver, options, keep tolerance) in the order tried
        self._weights = _weight_matrix(weights, self.plan.size)
        self._inverse_root = np.linalg.inv(np.linalg.cholesky(self._weights)).T  # W^-1/2 = L^-T, W = L L^T
        self.damping = damping if isinstance(damping, VariableDamping) else check_damping(damping)
        self.maximum = speed_maximum(robot.nv, self.plan.speed_limits)  # (nv,)
        self._rate_rows = RateRows.of(self.plan.joint_limits, valid_set=True)  # the valid sets' rows, stacked once
        self._unbounded = np.full(robot.nv, -np.inf), np.full(robot.nv, np.inf)

    def velocity(self, configuration: Configuration) -> SolverResult:
        """The velocity of the QP hierarchy at ``configuration``: the objectives active when a constraint binds
        or is relaxed; ``extras`` has ``solver_status`` and ``slacks`` per level and the ``solver`` used."""
        hierarchy = self.plan.evaluate(self._checked(configuration))
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
            if isinstance(objective, JointLimits):
                index = objective.v_index - offset
                freedom[index] = np.minimum(freedom[index], 1.0 - rows.activation)
    return freedom


def level_damping(equality: np.ndarray, freedom: np.ndarray | None, inverse_root: np.ndarray,
                  damping: float | VariableDamping) -> float:
    """lambda of a level with task rows E (k, n): fixed, or amundsen2018 eq. 6 of sigma_min of
    E diag(freedom) W^-1/2 (the columns the joint limits hold taken out; ``freedom`` read only by a variable
    damping); 0 without task rows."""
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


def _installed() -> list[str]:
    import qpsolvers

    return list(qpsolvers.available_solvers)


def _weight_matrix(weights: np.ndarray | None, size: int) -> np.ndarray:
    if weights is None:
        return np.eye(size)
    weights = check_weights(weights, size)
    return np.diag(weights) if weights.ndim == 1 else weights
