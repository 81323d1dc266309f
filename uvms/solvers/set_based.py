"""Set-based task priority, iCAT style: inequality objectives above the equality tasks, no jump at transitions.

Reference: E. Simetti and G. Casalino, "A novel practical technique to integrate inequality control
objectives and task transitions in priority based control", Journal of Intelligent & Robotic Systems
84 (2016) 877-902 (iCAT: inequality constraints and task transitions).

Levels, highest priority first; each level stacks its objectives' rows: Jacobian J_k (m, n), reference
xdot_k (m,) and activation A_k = diag(a) (equality tasks: a = 1, reference xdot_d + K e; inequality
objectives: their activation and reference, :mod:`uvms.tasks.objectives`). With rho_0 = 0, Q_0 = I:

    X^{#,A,Q} = (X^T A X + eta (I - Q)^T D^2 (I - Q) + lambda^2 M)^# X^T A A   (the iCAT inverse, X = J Q)
    W_k       = J_k Q_{k-1} (J_k Q_{k-1})^{#,A_k,Q_{k-1}}          (undamped)
    rho_k     = rho_{k-1} + Q_{k-1} (J_k Q_{k-1})^{#,A_k,I} W_k (xdot_k - J_k rho_{k-1})
    Q_k       = Q_{k-1} (I - (J_k Q_{k-1})^{#,A_k,I} J_k Q_{k-1})

with M the weights of the solved columns (``weights``, the W of CLIK; I by default) and D = diag of the
column norms of A^1/2 J (how much each solved coordinate moves the level's rows).
X^{#,A,Q} minimizes |A (xdot - X y)|^2 + |X y|^2_{A (I - A)} + eta |D (I - Q) y|^2 (+ lambda^2 |y|^2_M):
a row whose activation falls to 0 fades out continuously, and the eta term keeps directions already used
by the levels above from being inverted when they are only partly released, so no activation change
causes a discontinuity. Both inverses are the library's one inverse
(:class:`~uvms.numerics.inverses.WeightedInverse`, that of :func:`~uvms.numerics.inverses.damped_weighted_inverse`) of
the stack Z = [A^1/2 X; eta^1/2 D (I - Q)]. Adaptations, stated: the paper's singular-value
regularization V^T P V is the damping lambda of that inverse (fixed, or amundsen2018 eq. 6 variable), put
in (J Q)^{#,A,I} only; W_k uses the undamped inverse, so that with Q = I and A = I the step is
J^# J J^+ xdot = J^# xdot exactly (J J^+ projects on the range of J, on which J^# acts). The eta term
is the paper's eta |(I - Q) y|^2 with each coordinate weighed by its column in the level, D. Why: the paper's term
weighs a direction the same whatever the level's Jacobian does with it, so a column the level barely moves (the
jaw of the Alpha 5 in a free-floating tool-point task, ~1e-3 of the others) would be taken up only when the level
above has released all but ~1e-3 of it, within a sliver of the activation bell: a rate jump that does not shrink
with dt. Weighed by D, the penalty and X^T A X share their units and scale, the direction is handed over across
the whole band, and the largest change of a joint rate between two steps shrinks with dt
(``tests/solvers/test_hierarchy_quality.py`` holds it).

Hence with every inequality inactive (A = 0: rho and Q untouched) the result is CLIK,
:class:`~uvms.solvers.clik.CLIKSolver` with the same gain, weights and damping, to rounding (that case
calls the inverse exactly as CLIK does). Speed and position-rate bounds are met by scaling the lowest
levels' contributions first (:mod:`uvms.solvers.saturation`). With ``free_floating`` only the arm is
solved: every Jacobian is its generalized form (the one GJM formula) and the vehicle follows momentum
conservation, as in CLIK.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..numerics.checks import check_damping, check_scalar
from ..numerics.inverses import (
    RCOND,
    SolverInputError,
    VariableDamping,
    WeightedInverse,
    converged_or_refused,
    damping_parameters,
)
from ..robot.configuration import Configuration
from ..robot.robot import Robot
from ..tasks.objectives import VelocityLimit
from .base import Solver
from .hierarchy import Hierarchy, HierarchyPlan, Levels, last_task_sigma, solved_rows, speed_ratio
from .item_rows import ItemRows
from .result import SolverResult
from .saturation import TOLERANCE, RateRows, speed_maximum


# ----------------------------------------------------------------------------- the iCAT levels
class ICAT:
    """The iCAT inverses of one problem, their weights, damping and eta prepared once.

    Args:
        size: the number of solved columns n.
        weights: W of the solved columns, (n,) or (n, n) SPD, or None (I).
        damping: lambda >= 0 (fixed) or a VariableDamping, in (J Q)^{#,A,I} only.
        eta: weight of the eta (I - Q)^T D^2 (I - Q) term [-] >= 0.

    Raises:
        SolverInputError: a bad W, damping or eta.
    """

    def __init__(self, size: int, weights: np.ndarray | None, damping: float | VariableDamping, eta: float) -> None:
        self.size, self.eta = size, check_scalar(eta, "eta")
        self.inverse = WeightedInverse(weights, size)  # (rows (r, n), damping) -> inverse (n, r), sigma_min, used
        self.damping = damping if isinstance(damping, VariableDamping) else check_damping(damping)
        self._root_eta = np.sqrt(self.eta)
        self._kernel_constants = (*self.inverse.kernel_weights, *damping_parameters(self.damping), RCOND, self.eta)
        # numba: loaded where a solver is built, not by ``import uvms``
        from ..numerics._kernels.icat import icat_into, icat_saturated_into

        self._icat_into, self._icat_saturated_into = icat_into, icat_saturated_into
        # solve_saturated's buffers (the levels' contributions, scales and, for v alone, sigma_min), sized at its first
        # call
        self._scratch = np.empty((0, size)), np.empty(0), np.empty(0)

    def level_inverse(self, jacobian: np.ndarray, root: np.ndarray, power: np.ndarray, projector: np.ndarray | None,
                      damping: float | VariableDamping) -> tuple[np.ndarray, float, float]:
        """X^{#,A,Q} (n, m) of X = ``jacobian`` Q (J (m, n) unprojected; module docstring), root = a^1/2 (m, 1),
        power = a^1.5 (m,); sigma_min of the weighted Z and the damping used (projector None: Q = I, no eta
        rows); the inverse of each level of :meth:`solve` (:func:`~uvms.numerics._kernels.icat.level_inverse_into`).

        Raises:
            NumericalError: the SVD did not converge (a non-finite level).
        """
        from ..numerics._kernels.icat import eta_rows, level_inverse_into  # numba: loaded at the first solve

        unprojected = np.ascontiguousarray(root * jacobian, dtype=float)  # A^1/2 J
        scaled = unprojected if projector is None else np.ascontiguousarray(unprojected @ projector)  # A^1/2 X
        inverse = np.empty((self.size, jacobian.shape[0]))
        penalty = (eta_rows(unprojected, np.ascontiguousarray(projector, dtype=float), self._root_eta)
                   if projector is not None and self.eta > 0 else np.zeros((0, self.size)))
        converged, sigma_min, used = level_inverse_into(
            scaled, np.ascontiguousarray(power, dtype=float), penalty, *self.inverse.kernel_weights,
            *damping_parameters(damping), RCOND, 0.0, inverse)
        return inverse, *converged_or_refused(converged, scaled.shape, sigma_min, used)

    def solve(self, hierarchy: Hierarchy, offsets: np.ndarray,
              equality: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
        """The iCAT recursion over the levels: each level's contribution rho_k - rho_{k-1} (L, n), its sigma_min
        (L,), and the largest damping used (one compiled call, :func:`~uvms.numerics._kernels.icat.icat_into`);
        ``offsets`` (L + 1,) and ``equality`` (L,) of the levels as :class:`HierarchyPlan` lays them out.

        Raises:
            NumericalError: an inverse did not converge (a non-finite level).
        """
        count = equality.size
        contributions, sigmas = np.empty((count, self.size)), np.empty(count)
        if not count:
            return contributions, sigmas, 0.0
        jacobians = hierarchy.solved
        converged, largest = self._icat_into(jacobians, hierarchy.references, hierarchy.activations, offsets, equality,
                                             *self._kernel_constants, contributions, sigmas)
        if not converged:
            converged_or_refused(converged, jacobians.shape, 0.0, 0.0)
        return contributions, sigmas, largest

    def solve_saturated(self, stacks: tuple[np.ndarray, np.ndarray, np.ndarray], offsets: np.ndarray,
                        equality: np.ndarray, q: np.ndarray, box: tuple,
                        new_sigmas: bool = True) -> tuple[np.ndarray, np.ndarray, float, np.ndarray, float]:
        """:meth:`solve`, then the levels' sum inside the velocity box at q, in one compiled call
        (:func:`~uvms.numerics._kernels.icat.icat_saturated_into`; ``stacks``: the solved columns (M, n), the
        references (M,) and the activations (M,); ``box``: its arguments from q_index to the tolerance): the solved
        columns (n,), the sigma_min (L,) (a new array with ``new_sigmas``, else this object's buffer), the largest
        damping used, the scales (L,) (this object's buffer: read before the next call) and the speed ratio of the
        sum. For a hierarchy with levels whose solved columns are v (not free floating).

        Raises:
            NumericalError: an inverse did not converge (a non-finite level).
        """
        count = equality.size
        if self._scratch[1].size != count:
            self._scratch = np.empty((count, self.size)), np.empty(count), np.empty(count)
        contributions, scales, kept_sigmas = self._scratch
        total, sigmas = np.empty(self.size), np.empty(count) if new_sigmas else kept_sigmas
        converged, largest, ratio = self._icat_saturated_into(*stacks, offsets, equality, *self._kernel_constants, q,
                                                              *box, contributions, sigmas, total, scales)
        if not converged:
            converged_or_refused(converged, stacks[0].shape, 0.0, 0.0)
        return total, sigmas, largest, scales, ratio


# ------------------------------------------------------------------------------- the solver
class SetBasedSolver(Solver):
    """Set-based (iCAT) priority over fixed levels (scenario method "set_based"), its inputs checked and its
    pieces prepared once; what changes between calls is the configuration and the tasks' targets.

    Args:
        robot: the model.
        levels: highest priority first; each level a Task, an Inequality, or a list of them. Speed limits
            (VelocityLimit) may sit in any level: they are bounds, not rows.
        gain: K of the equality tasks (scalar, (k,) or (k, k) per level's stacked tasks) [1/s].
        weights: W of the solved columns, (n,) or (n, n) SPD, n = nv (n_arm when free floating).
        damping: lambda >= 0 or a VariableDamping, as in CLIK.
        eta: weight of the iCAT regularization ``eta |D (I - Q) y|^2`` [-] >= 0. It keeps a level off what the
            levels above partly hold, which is also why a task stops inside an objective's activation band;
            0 lets the task use the band (it reaches the valid set's border), without that protection
            (:mod:`uvms.tasks.objectives.base`, "What the band costs").
        free_floating: solve the arm only, the vehicle passive (generalized Jacobians).
        dt: step [s]; when given, the model's joint limits of every JointLimits objective become
            position-rate bounds (a joint never crosses them over the step).
        position_fraction: the part of the distance to a limit one step may cover, in (0, 1].
        speed_limits: more speed limits (besides those in the levels).

    Raises:
        SolverInputError: malformed levels, a bad gain, weight, damping, eta, dt or position_fraction,
            free_floating on a fixed base.
    """

    name = "set_based"
    enforces_inequalities = True
    shares_rows = True

    def __init__(
        self,
        robot: Robot,
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
    ) -> None:
        self.plan = HierarchyPlan(robot, levels, gain, free_floating, speed_limits)
        self.robot, self.free_floating = robot, free_floating
        self.icat = ICAT(self.plan.size, weights, damping, eta)
        self.fraction = check_scalar(position_fraction, "position_fraction", positive=True)
        if self.fraction > 1:
            raise SolverInputError(f"position_fraction must be in (0, 1], got {position_fraction!r}")
        self.dt = None if dt is None else check_scalar(dt, "dt", positive=True)
        self.maximum = speed_maximum(robot.nv, self.plan.speed_limits)  # (nv,)
        rates = self.dt is not None and bool(self.plan.joint_limits)  # position-rate bounds at every q
        rows = RateRows.of(self.plan.joint_limits if rates else [])  # their rows, stacked once (none without dt)
        from ..numerics._kernels.boxes import saturated_sum_into  # numba: loaded where a solver is built

        self._box_constants = (saturated_sum_into, rows.q_index, rows.v_index, rows.low, rows.high, self.dt or 1.0,
                               self.fraction,
                               self.maximum, not free_floating, TOLERANCE)
        self._box = (rows.q_index, rows.v_index, rows.low, rows.high, self.dt or 1.0, self.fraction, self.maximum,
                     TOLERANCE)  # the same box, as the fused call takes it (ICAT.solve_saturated)

    def velocity(self, configuration: Configuration, shared: ItemRows | None = None) -> SolverResult:
        """The set-based velocity at ``configuration`` and its diagnostics (sigma_min, the residuals and the
        objectives' statuses computed when read); ``sigma_min`` that of the last level holding equality tasks;
        ``shared``: the items' rows already evaluated at ``configuration`` (:meth:`HierarchyPlan.evaluate`)."""
        v, hierarchy, sigmas, used, scales, ratio = self._solve(configuration, shared)
        return SolverResult(v, lambda: last_task_sigma(hierarchy, sigmas), used, lambda: solved_rows(hierarchy),
                            free_floating=self.free_floating, scales=scales,
                            speed_ratio=speed_ratio(v, self.maximum) if self.free_floating else ratio,
                            objectives=hierarchy.objective_rows)

    def stage_velocity(self, configuration: Configuration, shared: ItemRows | None = None) -> np.ndarray:
        """v (nv,) of :meth:`velocity` alone, the same numbers, without its diagnostics (an integrator's stage, a
        coordinated step's second solve): the plan's own stacks (:meth:`HierarchyPlan.stage_stacks`), no Hierarchy
        built."""
        plan = self.plan
        if not plan.levels or self.free_floating:
            return self._solve(configuration, shared)[0]
        state = self._checked(configuration)
        return self.icat.solve_saturated(plan.stage_stacks(state, shared), plan.offsets, plan.equality, state.q,
                                         self._box, new_sigmas=False)[0]

    def _solve(self, configuration: Configuration,
               shared: ItemRows | None) -> tuple[np.ndarray, Hierarchy, np.ndarray, float, tuple[float, ...], float]:
        """(v (nv,), the hierarchy, the levels' sigma_min (L,), the largest damping, the levels' scales, the speed
        ratio of the solved columns) at ``configuration``."""
        state = self._checked(configuration)
        plan = self.plan
        hierarchy = plan.evaluate(state, shared)
        if plan.levels and not self.free_floating:  # the recursion and the box in one compiled call
            solved, sigmas, used, scales, ratio = self.icat.solve_saturated(
                (hierarchy.solved, hierarchy.references, hierarchy.activations), plan.offsets, plan.equality, state.q,
                self._box)
            scales = tuple(scales.tolist())
        else:
            contributions, sigmas, used = self.icat.solve(hierarchy, plan.offsets, plan.equality)
            solved, scales, ratio = saturate(hierarchy, contributions, state.q, self._box_constants)
        return hierarchy.velocity(solved), hierarchy, sigmas, used, scales, ratio


def saturate(hierarchy: Hierarchy, contributions: np.ndarray, q: np.ndarray,
             box: tuple) -> tuple[np.ndarray, tuple[float, ...], float]:
    """The solved columns (n,): the levels' contributions (L, n) summed in order, scaled lowest first so that v
    stays inside the velocity box at q (``box``: :func:`~uvms.numerics._kernels.boxes.saturated_sum_into`, then
    its constants after the contributions and q); the scales; the speed ratio of that sum (0 when free floating:
    v is formed from it after)."""
    saturated_sum_into, *constants = box
    if not contributions.shape[0]:
        return np.zeros(hierarchy.size), (), 0.0
    velocities = (np.array([hierarchy.to_velocity(c) for c in contributions]) if hierarchy.free_floating
                  else contributions)
    total, scales = np.empty(hierarchy.size), np.empty(contributions.shape[0])
    ratio = saturated_sum_into(contributions, velocities, q, *constants, total, scales)
    return total, tuple(scales.tolist()), ratio
