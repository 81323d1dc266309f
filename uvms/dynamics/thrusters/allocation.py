"""Thrust allocation: the thrusts f (n,) that give a body wrench tau (6,) = B f within the thrusters' limits.

Three steps, the cheap one first:

1. the minimum-norm solution f = B^+ tau (one matrix-vector product with a pseudo-inverse computed once);
   when it lies within [lower, upper] and reproduces tau, it is the answer and no solver runs;
2. otherwise a lexicographic bounded least squares over priority groups of wrench axes: the first group
   minimizes |W_1 (B_1 f - tau_1)| over lower <= f <= upper (scipy's ``lsq_linear``, bounded least squares),
   each further group does the same subject to keeping the wrench of the groups above it
   (B_j f = B_j f_j*), a QP solved by DAQP through ``qpsolvers``;
3. the thrusts of least norm that keep the achieved wrench (a QP): among the many thrust vectors that give
   one wrench (n > 6), the one that spends least.

With one group of all six axes (the default) the achieved wrench is the bounded least-squares optimum
B f* with f* = argmin |W (B f - tau)| s.t. bounds.

The rank of B is judged with a tolerance that matches the physics (:data:`.reach.RANK_TOLERANCE`, relative to the
largest singular value), not numpy's rounding-level one: a wrench direction that a layout gives only through rounding (a
roll moment from vertical thrusters placed 1e-10 m off the centre line) is not reachable, and every stage works on B
truncated to its reachable directions. Otherwise a pair of nearly dependent thrusters is driven to opposite limits
to produce a newton of it, and no least-norm step runs (the matrix looks square and full rank).
:attr:`ThrustAllocator.unreachable` names the directions left out.
"""

from __future__ import annotations

from collections.abc import Sequence
from ctypes import c_int
from dataclasses import dataclass

import numpy as np

from ...errors import SolverInputError, UVMSError
from ...numerics._kernels import Kernel
from ...numerics.inverses import pinv
from ...robot.conventions import AXIS_NAMES
from ...robot.kinematics import axis_rows
from .reach import rank, reachable_directions

#: Slack [N] on the bounds and the wrench when deciding that the pseudo-inverse solution is good enough.
TOLERANCE = 1e-9


@dataclass(slots=True)
class AllocationResult:
    """What one allocation gives (built at every step: plain attribute writes; read it, it is never changed).

    Attributes:
        thrusts: f (n,) [N], within [lower, upper].
        saturated: (n,) bool, the thrusts at a bound.
        achieved_wrench: B f (6,) [N, N m], body FLU at the base frame origin.
        residual: tau - B f (6,) [N, N m].
        attainable: True when tau itself is attained (within the tolerance).
        solver: "pinv" (no solver ran) or "bounded" (the lexicographic bounded least squares).
    """

    thrusts: np.ndarray
    saturated: np.ndarray
    achieved_wrench: np.ndarray
    residual: np.ndarray
    attainable: bool
    solver: str


class ThrustAllocator:
    """Allocation of body wrenches to thrusters with bounds and axis priorities.

    Args:
        matrix: B (6, n) (:func:`uvms.dynamics.thrusters.thrusters.allocation_matrix`).
        lower, upper: (n,) thrust bounds [N], lower <= 0 <= upper.
        priorities: groups of wrench axes, highest first, e.g. ``[("z", "roll", "pitch"), ("x", "y", "yaw")]``
            (attitude and depth before surge, sway and yaw); the names of ``uvms.robot.conventions.AXIS_NAMES``
            (x, y, z forces, roll, pitch, yaw moments); axes left out are not allocated. None: one group of all six.
        weights: (6,) > 0 per-axis weights of the least squares (e.g. 1/N and 1/(N m) scales); None: ones.
        tolerance: [N] slack deciding that B^+ tau is within bounds and exact.

    Raises:
        SolverInputError: shapes, non-finite numbers, bounds that exclude 0, bad axis names or weights.
    """

    def __init__(self, matrix: np.ndarray, lower: np.ndarray, upper: np.ndarray, *,
                 priorities: Sequence[Sequence[str]] | None = None, weights: np.ndarray | None = None,
                 tolerance: float = TOLERANCE) -> None:
        self.matrix = _finite(matrix, "allocation matrix B", 2)
        if self.matrix.shape[0] != 6 or self.matrix.shape[1] == 0:
            raise SolverInputError(f"B must be (6, n) with n >= 1 thrusters, got {self.matrix.shape}")
        n = self.matrix.shape[1]
        self.lower, self.upper = _finite(lower, "lower", 1), _finite(upper, "upper", 1)
        if self.lower.shape != (n,) or self.upper.shape != (n,) or np.any(self.lower > 0) or np.any(self.upper < 0):
            raise SolverInputError(f"lower and upper must be {n} bounds with lower <= 0 <= upper [N], got "
                                   f"{self.lower.tolist()} and {self.upper.tolist()}")
        self.weights = np.ones(6) if weights is None else _finite(weights, "weights", 1)
        if self.weights.shape != (6,) or np.any(self.weights <= 0):
            raise SolverInputError(f"weights must be 6 numbers > 0, got {weights!r}")
        self.groups = _priority_groups(priorities)
        self.tolerance = float(tolerance)
        # the bounds B^+ tau may touch within the slack (the attainable case's test, prepared once)
        self._inside = (self.lower - self.tolerance, self.upper + self.tolerance)
        self.reachable, self.unreachable = reachable_directions(self.matrix)  # B on its reachable directions (6, n)
        self.inverse = pinv(self.reachable)  # (n, 6), computed once: the attainable case is one product
        self._rows = sorted(row for group in self.groups for row in group)
        self._all_rows = len(self._rows) == 6
        self._plain = len(self.groups) == 1 and bool(np.all(self.weights == self.weights[0]))
        self._none_saturated = np.zeros(n, dtype=bool)  # the pseudo-inverse step's saturated (shared: read only)
        self._none_saturated.flags.writeable = False
        self._bounded: BoundedProblem | None = None  # the bounded stages' fixed arrays, made at their first use

    @property
    def n(self) -> int:
        """Number of thrusters."""
        return self.matrix.shape[1]

    def reach_note(self, names: Sequence[str], actuators: str = "thrusters") -> str:
        """One sentence on what the thrusters cannot produce ("" when they produce every direction).

        Args:
            names: the thrusters' names, in the order of B's columns; actuators: what the columns are, for the text.
        """
        if not self.unreachable:
            return ""
        parts = []
        for direction in self.unreachable:
            kind = "force" if AXIS_NAMES.index(direction.axis) < 3 else "moment"
            part = f"a {direction.axis} {kind}"
            if direction.thrusters:
                part += (f" (only through {', '.join(names[i] for i in direction.thrusters)} pushing against each "
                         f"other: {direction.ratio:.1e} of the layout's largest authority)")
            parts.append(part)
        them = "it" if len(parts) == 1 else "them"
        return (f"the {actuators} produce {self.rank} of the 6 body-wrench directions; missing: {', '.join(parts)} "
                f"(each named by its largest component); the allocation leaves {them} to the vehicle's own dynamics "
                f"(buoyancy, damping) rather than drive {actuators} to their limits for {them}")

    @property
    def rank(self) -> int:
        """The number of independent wrench directions the thrusters produce (6 for a fully actuated vehicle)."""
        return 6 - len(self.unreachable)

    def unconstrained(self, wrench: np.ndarray) -> np.ndarray:
        """The minimum-norm thrusts B^+ tau (n,) [N], bounds ignored."""
        return self.inverse @ _wrench(wrench)

    def allocate(self, wrench: np.ndarray, twist: np.ndarray | None = None,
                 current: np.ndarray | None = None) -> AllocationResult:
        """The thrusts for ``wrench`` (6,) [N, N m] within the bounds (module docstring); ``twist`` and ``current``
        are not used (a thruster's column does not change with the velocity; fins': :mod:`.fin_allocation`).

        Raises:
            SolverInputError: a wrench that is not 6 finite numbers.
            UVMSError: the QP solver failed (it should not: every stage is feasible by construction).
        """
        if self._all_rows:
            # the least-squares optimum of least norm on the reachable directions (B_r B_r^+ is the projection on
            # them); within the bounds it is the answer, exact unless tau has an unreachable part. One compiled
            # call (:func:`uvms.numerics._kernels.allocation.pseudo_inverse_thrusts`: numpy's numbers)
            if not (wrench.__class__ is np.ndarray and wrench.shape == (6,) and wrench.dtype == float
                    and wrench.flags.c_contiguous):
                wrench = np.ascontiguousarray(_wrench(wrench))
            kernel = _PSEUDO_INVERSE.function or _PSEUDO_INVERSE.load()
            thrusts, achieved, residual = np.empty(self.n), np.empty(6), np.empty(6)  # new: a result keeps them
            finite, within, exact = kernel(self.inverse, self.matrix, wrench, *self._inside, self.lower, self.upper,
                                           self.tolerance, thrusts, achieved, residual)
            if not finite:
                _wrench(wrench)  # raises: a wrench entry is not finite
            # short of tau (an unreachable part), the plain least squares is the answer only when no priority
            # or weight orders the axes; else the lexicographic stages trade the part off by them
            if within and (exact or self._plain):
                return AllocationResult(thrusts, self._none_saturated, achieved, residual, exact, "pinv")
        else:
            wrench = _wrench(wrench)
        return self._result(self._least_norm(self._lexicographic(wrench)), wrench, "bounded")

    # ------------------------------------------------------------------ the bounded stages
    def _lexicographic(self, wrench: np.ndarray) -> np.ndarray:
        """Thrusts minimizing each priority group's weighted residual in turn, keeping the groups above."""
        problem = self._bounded if self._bounded is not None else self._prepare()
        thrusts = None
        for stage in problem.stages:
            b = stage.weights * wrench[stage.group]
            if stage.kept is None:  # the first group: bounded least squares
                thrusts = self._least_squares(stage.matrix, b, problem.ordered)
            else:  # keep the groups above: B_kept f = B_kept f*
                thrusts = self._solve_qp(stage.hessian, stage.negated @ b, stage.kept, thrusts)
            thrusts = np.minimum(np.maximum(thrusts, self.lower), self.upper)  # np.clip's numbers, not its dispatch
        return thrusts

    def _least_squares(self, a: np.ndarray, b: np.ndarray, ordered: bool) -> np.ndarray:
        """argmin |a f - b| over lower <= f <= upper (scipy's ``lsq_linear``, BVLS). Its first step, the unbounded
        least squares (``np.linalg.lstsq``), is its answer when within the bounds: taken here without its checks
        (when the bounds are ordered, which it would refuse otherwise), the same numbers."""
        if ordered:
            thrusts = np.linalg.lstsq(a, b, rcond=-1)[0]
            if np.all((thrusts >= self.lower) & (thrusts <= self.upper)):
                return thrusts
        from scipy.optimize import lsq_linear  # when first saturated: scipy.optimize costs 0.2 s to import

        return lsq_linear(a, b, bounds=(self.lower, self.upper), method="bvls", tol=1e-12).x

    def _least_norm(self, thrusts: np.ndarray) -> np.ndarray:
        """The thrusts of least norm within bounds giving the same allocated wrench rows as ``thrusts``."""
        problem = self._bounded if self._bounded is not None else self._prepare()
        if problem.rows is None:
            return thrusts  # no freedom left: the wrench fixes the thrusts
        return np.minimum(np.maximum(self._solve_qp(problem.identity, problem.zeros, problem.rows, thrusts),
                                     self.lower), self.upper)

    def _solve_qp(self, p: np.ndarray, q: np.ndarray, rows: Equalities, thrusts: np.ndarray) -> np.ndarray:
        """min 1/2 x^T P x + q^T x s.t. A x = A f (``rows``, f = ``thrusts``), bounds, by DAQP; f is feasible, and
        kept if DAQP fails.

        DAQP's own API, given the arrays ``qpsolvers.solve_qp(..., solver="daqp")`` builds for it (the bounds, then
        the equality rows with sense 5): the same numbers without its problem object and checks at every call.
        """
        import daqp  # a compiled module (a dependency), loaded when the allocation first saturates

        # P is only semi-definite (fewer wrench rows than thrusters): DAQP's proximal-point iterations
        # (eps_prox > 0) solve such a QP exactly, where a regularization of P would move the optimum
        upper = rows.upper.copy()
        upper[self.n:] = (rows.left @ (rows.matrix @ thrusts)) / rows.singular  # A x = b on the independent rows
        solution, _, exitflag, _ = daqp.solve(p, q, rows.independent, upper, rows.lower, rows.sense, primal_start=None,
                                              eps_prox=1e-6)
        if exitflag <= 0 or not np.all(np.isfinite(solution)):
            return thrusts  # the previous stage's thrusts satisfy every constraint
        return solution

    def _prepare(self) -> BoundedProblem:
        """The bounded stages' arrays that do not change from call to call (B, the bounds, priorities and weights
        are fixed), made at the first bounded allocation."""
        stages, kept = [], []
        for group in self.groups:
            weights = self.weights[group]
            a = weights[:, None] * self.reachable[group]
            if not kept:
                stages.append(Stage(group, weights, a, None, None, None))
            else:
                stages.append(Stage(group, weights, a, a.T @ a, -a.T, Equalities.of(self.reachable[kept], self)))
            kept += list(group)
        rows = self.reachable[self._rows]
        least_norm = None if self.n <= rank(rows) else Equalities.of(rows, self)
        self._bounded = BoundedProblem(tuple(stages), least_norm, np.eye(self.n), np.zeros(self.n),
                                       not bool(np.any(self.lower >= self.upper)))
        return self._bounded

    def _result(self, thrusts: np.ndarray, wrench: np.ndarray, solver: str) -> AllocationResult:
        achieved = self.matrix @ thrusts
        residual = wrench - achieved
        scale = max(1.0, float(np.max(np.abs(wrench))))
        saturated = (thrusts <= self.lower + 1e-9 * scale) & (self.lower < 0) | (thrusts >= self.upper - 1e-9 * scale)
        attainable = bool(np.max(np.abs(residual[self._rows])) <= 1e-6 * scale)
        return AllocationResult(thrusts, saturated, achieved, residual, attainable, solver)


# ------------------------------------------------------------------ helpers
def _finite(value: object, what: str, ndim: int) -> np.ndarray:
    try:
        array = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise SolverInputError(f"{what} must be numbers, got {value!r}") from None
    if array.ndim != ndim or not np.all(np.isfinite(array)):
        raise SolverInputError(f"{what} must be a finite {'vector' if ndim == 1 else 'matrix'}, got {value!r}")
    return array


def _wrench(wrench: np.ndarray) -> np.ndarray:
    if isinstance(wrench, np.ndarray) and wrench.shape == (6,) and wrench.dtype == float \
            and np.isfinite(wrench).all():
        return wrench  # the hot path: the vehicle controller's own array
    array = _finite(wrench, "wrench", 1)
    if array.shape != (6,):
        raise SolverInputError(f"a body wrench is 6 numbers [fx, fy, fz, mx, my, mz] (N, N m), got {array.shape}")
    return array


def _priority_groups(priorities: Sequence[Sequence[str]] | None) -> list[list[int]]:
    """Rows of each priority group; every axis at most once."""
    if priorities is None:
        return [list(range(6))]
    try:
        groups = [axis_rows([group] if isinstance(group, str) else list(group)) for group in priorities]
        axis_rows([axis for group in priorities for axis in ([group] if isinstance(group, str) else group)])
    except UVMSError as exc:
        raise SolverInputError(f"priorities: {exc} (groups of {', '.join(AXIS_NAMES)}, each axis once)") from None
    if not groups or any(not group for group in groups):
        raise SolverInputError("priorities must be non-empty groups of wrench axes, highest first")
    return groups


@dataclass(frozen=True)
class Equalities:
    """Equality rows A x = A f of a bounded stage, A (m, n) fixed, prepared once for DAQP (which refuses dependent
    rows): A = U S V^T, so A x = b (consistent) <=> V_r^T x = S_r^-1 U_r^T b on the rank rows (singular values above
    1e-10 of the largest, at least 1), and DAQP's bound arrays with the equality rows after the thrusts' bounds.

    Attributes:
        matrix: A (m, n); independent: V_r^T (r, n) (an empty (0, n) when r = 0); left: U_r^T (r, m);
        singular: S_r (r,); upper, lower: (n + r,) the thrusts' bounds [N], then the rows' places (the upper ones
        filled per call, the lower ones -1e30); sense: (n + r,) DAQP's senses (5: an equality row).
    """

    matrix: np.ndarray
    independent: np.ndarray
    left: np.ndarray
    singular: np.ndarray
    upper: np.ndarray
    lower: np.ndarray
    sense: np.ndarray

    @classmethod
    def of(cls, matrix: np.ndarray, allocator: ThrustAllocator) -> Equalities:
        u, singular, vt = np.linalg.svd(matrix, full_matrices=False)
        rank = int(np.sum(singular > 1e-10 * max(1.0, singular[0] if singular.size else 0.0)))
        n = allocator.n
        upper, lower = np.empty(n + rank), np.full(n + rank, -1e30)
        upper[:n], lower[:n] = allocator.upper, allocator.lower
        sense = np.zeros(n + rank, dtype=c_int)
        sense[n:] = 5  # equality rows
        return cls(matrix, vt[:rank] if rank else np.zeros((0, n)), u[:, :rank].T, singular[:rank], upper, lower,
                   sense)


@dataclass(frozen=True)
class Stage:
    """One priority group's least squares |W_g (B_g f - tau_g)|, its arrays fixed: the wrench rows, W_g (k,),
    W_g B_g (k, n); its QP's P = (W_g B_g)^T W_g B_g (n, n), -(W_g B_g)^T (n, k) and the groups above it kept
    (:class:`Equalities`), the three None for the first group (a bounded least squares)."""

    group: list[int]
    weights: np.ndarray
    matrix: np.ndarray
    hessian: np.ndarray | None
    negated: np.ndarray | None
    kept: Equalities | None


@dataclass(frozen=True)
class BoundedProblem:
    """What the bounded stages of one ThrustAllocator read at every call: its :class:`Stage` s, the least-norm
    stage's rows (None: no freedom left), its P = I (n, n) and q = 0 (n,), and whether lower < upper everywhere
    (``lsq_linear`` refuses otherwise)."""

    stages: tuple[Stage, ...]
    rows: Equalities | None
    identity: np.ndarray
    zeros: np.ndarray
    ordered: bool


#: The compiled pseudo-inverse step (:func:`uvms.numerics._kernels.allocation.pseudo_inverse_thrusts`, numba loaded at
#: the first allocation).
_PSEUDO_INVERSE = Kernel("allocation", "pseudo_inverse_thrusts")
