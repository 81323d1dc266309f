"""Set-based task priority, iCAT style: inequality objectives above the equality tasks, no jump at transitions.

Reference: E. Simetti and G. Casalino, "A novel practical technique to integrate inequality control
objectives and task transitions in priority based control", Journal of Intelligent & Robotic Systems
84 (2016) 877-902 (iCAT: inequality constraints and task transitions).

Levels, highest priority first; each level stacks its objectives' rows: Jacobian J_k (m, n), reference
xdot_k (m,) and activation A_k = diag(a) (equality tasks: a = 1, reference xdot_d + K e; inequality
objectives: their activation and reference, :mod:`uvms.tasks.objectives`). With rho_0 = 0, Q_0 = I:

    X^{#,A,Q} = (X^T A X + eta (I - Q)^T (I - Q) + lambda^2 M)^# X^T A A          (the iCAT inverse)
    W_k       = J_k Q_{k-1} (J_k Q_{k-1})^{#,A_k,Q_{k-1}}          (undamped)
    rho_k     = rho_{k-1} + Q_{k-1} (J_k Q_{k-1})^{#,A_k,I} W_k (xdot_k - J_k rho_{k-1})
    Q_k       = Q_{k-1} (I - (J_k Q_{k-1})^{#,A_k,I} J_k Q_{k-1})

with M the weights of the solved columns (``weights``, the W of CLIK; I by default).
X^{#,A,Q} minimizes |A (xdot - X y)|^2 + |X y|^2_{A (I - A)} + eta |(I - Q) y|^2 (+ lambda^2 |y|^2_M): a
row whose activation falls to 0 fades out continuously, and the eta term keeps directions already used by
the levels above from being inverted when they are only partly released, so no activation change causes a
discontinuity. Both inverses are the library's one inverse
(:func:`~uvms.solvers.inverses.damped_weighted_inverse`) of the stack Z = [A^1/2 X; eta^1/2 (I - Q)],
since Z^T Z = X^T A X + eta (I - Q)^T (I - Q). Adaptations, stated: the paper's singular-value
regularization V^T P V is the damping lambda of that inverse (fixed, or amundsen2018 eq. 6 variable), put
in (J Q)^{#,A,I} only; W_k uses the undamped inverse, so that with Q = I and A = I the step is
J^# J J^+ xdot = J^# xdot exactly (J J^+ projects on the range of J, on which J^# acts).

Hence with every inequality inactive (A = 0: rho and Q untouched) the result is CLIK,
:func:`~uvms.solvers.clik.clik_velocity` with the same gain, weights and damping, to rounding (that case
calls the inverse exactly as CLIK does). Speed and position-rate bounds are met by scaling the lowest
levels' contributions first (:mod:`uvms.solvers.saturation`). With ``free_floating`` only the arm is
solved: every Jacobian is its generalized form (the one GJM formula) and the vehicle follows momentum
conservation, as in CLIK.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..integrate import euler_step
from ..kinematics import base_velocity_from_momentum, solve_base_block
from ..robot import Robot
from ..state import KinematicState
from ..tasks.objectives import Inequality, InequalityRows, JointLimits, VelocityLimit
from ..tasks.task import Task
from .checks import check_scalar, check_weights
from .inverses import SolverInputError, VariableDamping, damped_weighted_inverse
from .results import ObjectiveStatus, SetBasedResult, StepResult
from .saturation import position_rate_bounds, scale_lowest_first, speed_maximum, velocity_box
from .stack import stack

#: What a level may hold.
LevelItem = Task | Inequality | VelocityLimit
Levels = Sequence[LevelItem | Sequence[LevelItem]]


# ----------------------------------------------------------------- the hierarchy at one configuration
@dataclass
class LevelRows:
    """One level evaluated at a configuration.

    Attributes:
        index: its position in the levels given (0 = highest).
        jacobian: (m, nv) world-aligned rows; solved: (m, n) the columns solved (generalized when free floating).
        reference: (m,) the rows' reference rates; activation: (m,) in [0, 1].
        objectives: the inequality objectives' rows at this configuration; inequalities: the objectives.
        task_jacobian, task_error, task_command: the equality tasks' stacked rows (0 rows if none).
    """

    index: int
    jacobian: np.ndarray
    solved: np.ndarray
    reference: np.ndarray
    activation: np.ndarray
    objectives: list[InequalityRows] = field(default_factory=list)
    inequalities: list[Inequality] = field(default_factory=list)
    task_jacobian: np.ndarray | None = None
    task_error: np.ndarray | None = None
    task_command: np.ndarray | None = None

    @property
    def has_tasks(self) -> bool:
        return self.task_error is not None and self.task_error.size > 0


@dataclass
class Hierarchy:
    """The levels of a problem at one configuration, and how solved columns map to v.

    Attributes:
        state: the kinematic state.
        levels: the levels with rows (levels holding only speed limits are left out).
        speed_limits: the speed limits found in the levels or given.
        joint_limits: the joint-limit objectives (their limits become position-rate bounds).
        free_floating: only the arm is solved.
        vehicle_map: free floating: T_b (n_vehicle, n_arm) with v_vehicle = T_b qdot_arm; else None.
    """

    state: KinematicState
    levels: list[LevelRows]
    speed_limits: list[VelocityLimit]
    joint_limits: list[JointLimits]
    free_floating: bool
    vehicle_map: np.ndarray | None

    @property
    def size(self) -> int:
        """Number of solved columns n (nv, or n_arm when free floating)."""
        robot = self.state.robot
        return robot.n_arm if self.free_floating else robot.nv

    def to_velocity(self, solved: np.ndarray) -> np.ndarray:
        """A contribution in v (nv,) from solved columns (n,) (linear: the vehicle by T_b when free floating)."""
        if not self.free_floating:
            return solved
        return np.concatenate([self.vehicle_map @ solved, solved])

    def velocity(self, solved: np.ndarray) -> np.ndarray:
        """The full velocity v (nv,) of a solution: the vehicle from momentum conservation when free floating."""
        if not self.free_floating:
            return solved
        a_base, a_arm = self.state.centroidal_split()
        return np.concatenate([base_velocity_from_momentum(a_base, a_arm, solved, None), solved])


def split_levels(levels: Levels) -> tuple[list[tuple[int, list[Task | Inequality]]], list[VelocityLimit]]:
    """(index, tasks and inequalities) per level, and the speed limits found anywhere.

    Raises:
        SolverInputError: no level, an empty level, or an item that is not a Task, an Inequality or a
            VelocityLimit.
    """
    if isinstance(levels, (Task, Inequality, VelocityLimit)) or not len(levels):
        raise SolverInputError("levels must be a non-empty sequence of levels, each an objective or a list of them")
    rows, limits = [], []
    for index, level in enumerate(levels):
        items = [level] if isinstance(level, (Task, Inequality, VelocityLimit)) else list(level)
        if not items:
            raise SolverInputError(f"level {index} is empty")
        bad = [item for item in items if not isinstance(item, (Task, Inequality, VelocityLimit))]
        if bad:
            raise SolverInputError(f"level {index}: {bad[0]!r} is not a Task, an Inequality or a VelocityLimit")
        limits.extend(item for item in items if isinstance(item, VelocityLimit))
        solved = [item for item in items if not isinstance(item, VelocityLimit)]
        if solved:
            rows.append((index, solved))
    return rows, limits


def level_rows(state: KinematicState, index: int, items: list[Task | Inequality], gain: float | np.ndarray,
               free_floating: bool) -> LevelRows:
    """Stack one level's rows at ``state``: equality tasks first, then the inequalities in their order."""
    tasks = [item for item in items if isinstance(item, Task)]
    objectives = [item for item in items if isinstance(item, Inequality)]
    inequalities = [item.rows(state) for item in objectives]
    nv = state.robot.nv
    blocks, references, activations = [], [], []
    task_jacobian = task_error = task_command = None
    if tasks:
        task_jacobian, task_error, task_command = stack(state, tasks, gain)
        blocks.append(task_jacobian)
        references.append(task_command)
        activations.append(np.ones(task_error.size))
    for rows in inequalities:
        blocks.append(rows.jacobian)
        references.append(rows.reference)
        activations.append(rows.activation)
    jacobian = np.vstack(blocks) if blocks else np.zeros((0, nv))
    solved = state.generalized(jacobian) if free_floating else jacobian
    return LevelRows(index=index, jacobian=jacobian, solved=solved, reference=np.concatenate(references),
                     activation=np.concatenate(activations), objectives=inequalities, inequalities=objectives,
                     task_jacobian=task_jacobian,
                     task_error=task_error, task_command=task_command)


def build_hierarchy(robot: Robot, q: np.ndarray | KinematicState, levels: Levels, gain: float | np.ndarray,
                    free_floating: bool, speed_limits: Sequence[VelocityLimit] = ()) -> Hierarchy:
    """Evaluate every level at q (the state computed once), and the map of solved columns to v.

    Raises:
        SolverInputError: malformed levels, or ``free_floating`` on a fixed base.
    """
    if free_floating and robot.base_type == "fixed":
        raise SolverInputError(f"{robot.name} has a fixed base: free_floating=True needs a floating or planar base")
    items, found = split_levels(levels)
    state = q if isinstance(q, KinematicState) else KinematicState(robot, q)
    rows = [level_rows(state, index, level, gain, free_floating) for index, level in items]
    joint_limits = [item for _, level in items for item in level if isinstance(item, JointLimits)]
    vehicle_map = None
    if free_floating:
        a_base, a_arm = state.centroidal_split()
        vehicle_map = -solve_base_block(a_base, a_arm)  # (n_vehicle, n_arm)
    return Hierarchy(state=state, levels=rows, speed_limits=[*found, *speed_limits], joint_limits=joint_limits,
                     free_floating=free_floating, vehicle_map=vehicle_map)


# ----------------------------------------------------------------------------- the iCAT levels
def icat_inverse(jacobian: np.ndarray, activation: np.ndarray, projector: np.ndarray | None,
                 weights: np.ndarray | None, damping: float | VariableDamping,
                 eta: float) -> tuple[np.ndarray, float, float]:
    """X^{#,A,Q} (n, m) of the iCAT (module docstring), sigma_min of the weighted A^1/2 X (Q = None: I) and the
    damping used.

    Args:
        jacobian: X (m, n), the level's Jacobian times the projector of the levels above.
        activation: diag(A) (m,) in [0, 1].
        projector: Q (n, n) of the levels above, or None for Q = I (no eta term).
        weights: W of the solved columns, or None.
        damping: lambda (fixed or variable) of the one inverse.
        eta: weight of the eta (I - Q)^T (I - Q) term [-] >= 0.
    """
    rows = np.sqrt(activation)[:, None] * jacobian
    if projector is not None and eta > 0:
        rows = np.vstack([rows, np.sqrt(eta) * (np.eye(len(projector)) - projector)])  # Z (m + n, n)
    inverse, sigma_min, used = damped_weighted_inverse(rows, weights, damping)
    return inverse[:, : jacobian.shape[0]] * activation**1.5, sigma_min, used


def is_undamped(damping: float | VariableDamping) -> bool:
    """A fixed damping of 0: the damped and undamped iCAT inverses coincide."""
    return not isinstance(damping, VariableDamping) and float(damping) == 0.0


def solve_levels(hierarchy: Hierarchy, weights: np.ndarray | None, damping: float | VariableDamping,
                 eta: float) -> tuple[list[np.ndarray], list[float], float]:
    """The iCAT recursion over the levels: each level's contribution rho_k - rho_{k-1} (n,), its sigma_min, and
    the largest damping used."""
    size = hierarchy.size
    rho, projector = np.zeros(size), np.eye(size)
    unrestricted = True  # Q = I exactly: no level above has moved anything
    contributions, sigmas, largest = [], [], 0.0
    for level in hierarchy.levels:
        jacobian, activation = level.solved, level.activation
        if not np.any(activation > 0):
            contributions.append(np.zeros(size))
            sigmas.append(0.0)
            continue
        remaining = level.reference - jacobian @ rho
        if unrestricted and np.all(activation == 1.0):  # the CLIK case, solved exactly as clik_velocity does
            inverse, sigma_min, used = damped_weighted_inverse(jacobian, weights, damping)
            contribution = inverse @ remaining
            projector = projector - inverse @ jacobian
        else:  # rows with a = 0 add nothing to Z nor to the inverse (its columns scale by a^1.5): left out
            rows = activation > 0
            projected = jacobian[rows] if unrestricted else jacobian[rows] @ projector
            inverse, sigma_min, used = icat_inverse(projected, activation[rows], None, weights, damping, eta)
            regularized = inverse if unrestricted and is_undamped(damping) else icat_inverse(
                projected, activation[rows], None if unrestricted else projector, weights, 0.0, eta)[0]
            transfer = projected @ regularized  # W_k (m, m)
            contribution = projector @ (inverse @ (transfer @ remaining[rows]))
            projector = projector - projector @ (inverse @ projected)
        rho = rho + contribution
        unrestricted = False
        contributions.append(contribution)
        sigmas.append(sigma_min)
        largest = max(largest, used)
    return contributions, sigmas, largest


# --------------------------------------------------------------------------------- reporting
def objective_statuses(hierarchy: Hierarchy, binding: dict[str, bool] | None = None) -> tuple[ObjectiveStatus, ...]:
    """The inequality objectives' statuses; active = some activation > 0, or ``binding[name]`` when given."""
    statuses = []
    for level in hierarchy.levels:
        for rows in level.objectives:
            active = bool(np.any(rows.activation > 0)) if binding is None else binding.get(rows.name, False)
            statuses.append(ObjectiveStatus(name=rows.name, level=level.index, value=rows.value,
                                            activation=rows.activation, active=active, violation=rows.violation))
    return tuple(statuses)


def task_report(hierarchy: Hierarchy, v: np.ndarray) -> tuple[np.ndarray, np.ndarray, float, tuple[float, ...]]:
    """(command, error, |J v - command| of the equality tasks, per-level activation-weighted residuals)."""
    task_levels = [level for level in hierarchy.levels if level.has_tasks]
    command = np.concatenate([level.task_command for level in task_levels]) if task_levels else np.zeros(0)
    error = np.concatenate([level.task_error for level in task_levels]) if task_levels else np.zeros(0)
    achieved = np.concatenate([level.task_jacobian @ v for level in task_levels]) if task_levels else np.zeros(0)
    per_level = tuple(float(np.linalg.norm(level.activation * (level.jacobian @ v - level.reference)))
                      for level in hierarchy.levels)
    return command, error, float(np.linalg.norm(achieved - command)), per_level


def speed_ratio(v: np.ndarray, maximum: np.ndarray) -> float:
    """max_i |v_i| / max_i over the finite speed limits (0 without any)."""
    limited = np.isfinite(maximum)
    return float(np.max(np.abs(v[limited]) / maximum[limited], initial=0.0))


def last_task_sigma(hierarchy: Hierarchy, sigmas: Sequence[float]) -> float:
    """sigma_min of the last level holding equality tasks (0 if none)."""
    values = [sigma for level, sigma in zip(hierarchy.levels, sigmas) if level.has_tasks]
    return float(values[-1]) if values else 0.0


# ------------------------------------------------------------------------------- the step
def set_based_velocity(
    robot: Robot,
    q: np.ndarray | KinematicState,
    levels: Levels,
    *,
    gain: float | np.ndarray = 1.0,
    weights: np.ndarray | None = None,
    damping: float | VariableDamping = 0.0,
    eta: float = 1.0,
    free_floating: bool = False,
    dt: float | None = None,
    position_fraction: float = 1.0,
    speed_limits: Sequence[VelocityLimit] = (),
) -> SetBasedResult:
    """One set-based (iCAT) velocity over priority levels of equality tasks and inequality objectives.

    Args:
        robot: the model.
        q: configuration (nq,) or a KinematicState computed at it.
        levels: highest priority first; each level a Task, an Inequality, or a list of them. Speed limits
            (VelocityLimit) may sit in any level: they are bounds, not rows.
        gain: K of the equality tasks (scalar, (k,) or (k, k) per level's stacked tasks) [1/s].
        weights: W of the solved columns, (n,) or (n, n) SPD, n = nv (n_arm when free floating).
        damping: lambda >= 0 or a VariableDamping, as in CLIK.
        eta: weight of the iCAT (I - Q) regularization [-] >= 0.
        free_floating: solve the arm only, the vehicle passive (generalized Jacobians).
        dt: step [s]; when given, the model's joint limits of every JointLimits objective become
            position-rate bounds (a joint never crosses them over the step).
        position_fraction: the part of the distance to a limit one step may cover, in (0, 1].
        speed_limits: more speed limits (besides those in the levels).

    Returns:
        SetBasedResult: v (nv,), the objectives' activations, the task residual, the scales.
    """
    check_scalar(eta, "eta")
    fraction = check_scalar(position_fraction, "position_fraction", positive=True)
    if fraction > 1:
        raise SolverInputError(f"position_fraction must be in (0, 1], got {position_fraction!r}")
    hierarchy = build_hierarchy(robot, q, levels, gain, free_floating, speed_limits)
    if weights is not None:
        weights = check_weights(weights, hierarchy.size)
    contributions, sigmas, used = solve_levels(hierarchy, weights, damping, eta)
    maximum = speed_maximum(robot.nv, hierarchy.speed_limits)
    lower, upper = velocity_box(maximum, *rate_bounds(hierarchy, dt, fraction), contain_zero=True)
    solved, scales = saturate(hierarchy, contributions, lower, upper)
    v = hierarchy.velocity(solved)
    command, error, residual, level_residuals = task_report(hierarchy, v)
    return SetBasedResult(v=v, objectives=objective_statuses(hierarchy), command=command, error=error,
                          residual=residual, level_residuals=level_residuals,
                          sigma_min=last_task_sigma(hierarchy, sigmas), scales=scales,
                          speed_ratio=speed_ratio(v, maximum), free_floating=free_floating, damping=used)


def rate_bounds(hierarchy: Hierarchy, dt: float | None, fraction: float,
                valid_set: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Position-rate bounds (nv,) of the hierarchy's joint limits over ``dt`` (unbounded without dt)."""
    nv = hierarchy.state.robot.nv
    if dt is None or not hierarchy.joint_limits:
        return np.full(nv, -np.inf), np.full(nv, np.inf)
    dt = check_scalar(dt, "dt", positive=True)
    return position_rate_bounds(hierarchy.state.q, nv, hierarchy.joint_limits, dt, fraction, valid_set)


def saturate(hierarchy: Hierarchy, contributions: list[np.ndarray], lower: np.ndarray,
             upper: np.ndarray) -> tuple[np.ndarray, tuple[float, ...]]:
    """The solved columns (n,) with the levels scaled lowest first so that v stays inside the box."""
    if not contributions:
        return np.zeros(hierarchy.size), ()
    if not (np.isfinite(lower).any() or np.isfinite(upper).any()):
        return np.sum(contributions, axis=0), (1.0,) * len(contributions)
    _, scales = scale_lowest_first([hierarchy.to_velocity(c) for c in contributions], lower, upper)
    return np.sum([scale * c for scale, c in zip(scales, contributions)], axis=0), scales


def integrate_velocity(robot: Robot, q: np.ndarray, v: np.ndarray, dt: float) -> np.ndarray:
    """q+ = integrate(q, v dt) (nq,): the library's one explicit Euler step (:func:`uvms.integrate.euler_step`)."""
    empty = np.zeros(0)
    return euler_step(robot.model, None, 0.0, np.asarray(q, dtype=float), empty, dt, (v, empty))[0]


def set_based_step(robot: Robot, q: np.ndarray, levels: Levels, dt: float, **options) -> StepResult:
    """One explicit-Euler set-based step: q+ = integrate(q, v dt); ``options`` of :func:`set_based_velocity`."""
    dt = check_scalar(dt, "dt", positive=True)
    velocity = set_based_velocity(robot, q, levels, dt=dt, **options)
    return StepResult(q=integrate_velocity(robot, q, velocity.v, dt), velocity=velocity)
