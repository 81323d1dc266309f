"""One level of the QP hierarchy (:mod:`uvms.solvers.hqp`): the rows that keep the levels above at their optimum,
the QP solver chosen, and the level's QP over z = [x, w] solved.

DAQP is called through its own Python API with the arrays qpsolvers' DAQP interface would pass it (bit for bit
the same QP and solution, without building qpsolvers' problem object and running its checks at every level of every
step); the other solvers (ProxQP) go through qpsolvers. The QP's arrays are written by one compiled call
(:func:`uvms.numerics._kernels.qp.level_qp_into`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..numerics.inverses import SolverInputError

#: QP solvers tried, in order, when none is named.
PREFERRED_SOLVERS = ("daqp", "proxqp")
#: Retries of a solver whose QP failed: DAQP with proximal-point iterations copes with the degenerate
#: feasible sets a cascade produces (a level pinned to a vertex of the box by the optimum above).
RETRY_OPTIONS = {"daqp": {"eps_prox": 1e-6}}
#: Looser keep tolerances tried when a level's QP fails at KEEP_TOLERANCE.
LOOSER_KEEP_TOLERANCES = (1e-6, 1e-4)
#: Tolerance [same units as the rows] with which the rows of the levels above are kept at their optimum.
KEEP_TOLERANCE = 1e-9


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
    problem object and checks), every other solver through
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


def installed_solvers() -> list[str]:
    """The QP solvers qpsolvers finds installed."""
    import qpsolvers

    return list(qpsolvers.available_solvers)
