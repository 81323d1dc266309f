"""Result objects of the solvers: the solution and its diagnostics, never bare arrays.

:class:`SolverResult` is what every velocity solver (:class:`~uvms.solvers.base.Solver`) returns;
:class:`IKResult` and :class:`InitialConfigurationResult` answer another question (a configuration, not a
velocity). The residuals, the task command and error and the objectives' statuses are computed from the rows
the solver kept when they are first read (:func:`functools.cached_property`), not in the hot path; so are the
sigma_min and the rows a solver gives as functions (a prepared CLIK step computes them only when asked).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from types import MappingProxyType
from typing import NamedTuple

import numpy as np

from ..errors import SolverInputError
from ..tasks.objectives import InequalityRows


@dataclass(frozen=True)
class IKResult:
    """A pose inverse-kinematics solution.

    Attributes:
        q: best configuration found (nq,), inside the joint limits.
        success: error <= tolerance.
        error: norm of the stacked task error at ``q`` [m and rad].
        iterations: Newton iterations over all starts.
        restarts: random restarts used.
        time: wall time [s].
    """

    q: np.ndarray
    success: bool
    error: float
    iterations: int
    restarts: int
    time: float


@dataclass(frozen=True)
class InitialConfigurationResult:
    """The initial configuration of hoang2011 sec. 2.3: min S(q) s.t. f(q) = x0 and joint limits.

    Attributes:
        q: configuration (nq,).
        success: residual <= tolerance and limits respected.
        residual: ``|x0 - f(q)|``.
        potential: S(q).
        iterations: optimizer iterations.
        message: optimizer message.
    """

    q: np.ndarray
    success: bool
    residual: float
    potential: float
    iterations: int
    message: str = field(default="")


@dataclass(frozen=True)
class ObjectiveStatus:
    """An inequality objective in a solution of the set-based or QP hierarchy.

    Attributes:
        name: the objective's name.
        level: its priority level (0 = highest).
        value: x(q) (k,) at the configuration solved at.
        activation: (k,) in [0, 1] (0 deep inside the valid set, 1 on its border and beyond).
        active: set-based: some activation > 0; QP hierarchy: some constraint row binding or relaxed.
        violation: how far x is outside its valid set (>= 0) [units of x].
    """

    name: str
    level: int
    value: np.ndarray
    activation: np.ndarray
    active: bool
    violation: float


class SolvedRows(NamedTuple):
    """The rows one level (or one task) of a solution was solved for, kept to report on it when asked.

    Attributes:
        index: the level's position in the levels given (0 = highest).
        jacobian: (m, nv) world-aligned rows, columns in the order of v.
        reference: (m,) the rows' reference rates; the first ``error.size`` are the equality tasks' commands
            xdot_d + K e.
        error: (t,) the equality tasks' error e (t <= m; 0 rows: a level of inequality objectives only).
        activation: (m,) in [0, 1], or None: every row weighs 1.
        objectives: the inequality objectives' rows of this level, at the configuration solved at.
    """

    index: int
    jacobian: np.ndarray
    reference: np.ndarray
    error: np.ndarray
    activation: np.ndarray | None = None
    objectives: tuple[InequalityRows, ...] = ()

    def residual(self, v: np.ndarray) -> float:
        """``|A (J v - reference)|`` of the level (activation-weighted; equality rows weigh 1)."""
        difference = self.jacobian @ v - self.reference
        return float(np.linalg.norm(difference if self.activation is None else self.activation * difference))


#: The extras of a result that has none (read-only).
NO_EXTRAS: Mapping[str, object] = MappingProxyType({})


class SolverResult:
    """One velocity of a solver and its diagnostics, the same fields for every method (read them; a result is
    never changed after it is built).

    Built at every solver call, so building it costs a few attribute writes: what a solver can compute later
    (sigma_min after a Cholesky solve, the rows of a prepared step) it may give as a function of no argument,
    called when the field is first read; the residuals, command and error are computed from the levels when
    first read. v, sigma_min, damping and levels may be given by position, the others by name.

    Attributes:
        v: velocity (nv,) in the order of Pinocchio's v (vehicle twist local, then arm).
        damping: the (largest) damping lambda used (0: exact inverses or an undamped QP hierarchy).
        free_floating: whether only the arm was solved and the vehicle followed momentum conservation.
        limits_active: names of the arm joints held at a limit (CLIK's joint clamping).
        scales: per level, the factor in [0, 1] its contribution was scaled by to meet the speed and
            position-rate bounds (1: not scaled; the lowest levels are scaled first); () without bounds.
        speed_ratio: max_i ``|v_i|`` / max_i over the speed limits given (0 without any).
        extras: what one method alone reports (read-only): ``method`` (task priority: "classic" or
            "robust"), ``level_sigma_min`` (task priority: one per level), ``solver_status``, ``slacks`` and
            ``solver`` (QP hierarchy).

    ``objectives`` (by name): a function giving the inequality objectives' rows in priority order, those of
    :attr:`levels`, from which :attr:`activity` is read without forming the levels.
    """

    def __init__(self, v: np.ndarray, sigma_min: float | Callable[[], float], damping: float,
                 levels: tuple[SolvedRows, ...] | Callable[[], tuple[SolvedRows, ...]] = (), *,
                 free_floating: bool = False, limits_active: tuple[str, ...] = (), scales: tuple[float, ...] = (),
                 speed_ratio: float = 0.0, extras: Mapping[str, object] | None = None,
                 binding: Mapping[str, bool] | Callable[[], Mapping[str, bool]] | None = None,
                 objectives: Callable[[], Sequence[InequalityRows]] | None = None) -> None:
        self.v = v
        self._objective_rows = objectives
        self.damping = damping
        self.free_floating = free_floating
        self.limits_active = limits_active
        self.scales = scales
        self.speed_ratio = speed_ratio
        if callable(binding):  # computed when read
            self._binding = binding
        else:
            self.binding = binding
        self.extras = MappingProxyType(dict(extras)) if extras else NO_EXTRAS  # read-only, whatever mapping given
        if callable(sigma_min):  # computed when read
            self._sigma_min = sigma_min
        else:
            self.sigma_min = sigma_min
        if callable(levels):
            self._levels = levels
        else:
            self.levels = levels

    def __repr__(self) -> str:
        return (f"SolverResult(v={self.v!r}, sigma_min={self.sigma_min!r}, damping={self.damping!r}, "
                f"free_floating={self.free_floating!r}, limits_active={self.limits_active!r})")

    @cached_property
    def sigma_min(self) -> float:
        """The smallest singular value over the Jacobians the solver inverted (weighted, projected as it inverted
        them; the QP hierarchy: that of the last level's task rows)."""
        return float(self._sigma_min())

    @cached_property
    def binding(self) -> Mapping[str, bool] | None:
        """Per objective name, whether it binds (the QP hierarchy); None: active = some activation > 0."""
        return self._binding()

    @cached_property
    def levels(self) -> tuple[SolvedRows, ...]:
        """The rows solved, per level (or per task for CLIK), highest priority first; what :attr:`command`,
        :attr:`error`, :attr:`residual`, :attr:`task_residuals` and :attr:`objectives` are computed from."""
        return tuple(self._levels())

    @cached_property
    def command(self) -> np.ndarray:
        """The equality tasks' command xdot_d + K e (k,), every level in order."""
        parts = [level.reference[:level.error.size] for level in self.levels]
        return np.concatenate(parts) if parts else np.zeros(0)

    @cached_property
    def error(self) -> np.ndarray:
        """The equality tasks' error e (k,), every level in order."""
        return np.concatenate([level.error for level in self.levels]) if self.levels else np.zeros(0)

    @cached_property
    def residual(self) -> float:
        """``|J v - command|`` over every equality row (rows not achieved: damping, priorities, limits)."""
        parts = [level.jacobian[:level.error.size] @ self.v for level in self.levels]
        achieved = np.concatenate(parts) if parts else np.zeros(0)
        return float(np.linalg.norm(achieved - self.command))

    @cached_property
    def task_residuals(self) -> tuple[float, ...]:
        """Per level (per task for CLIK), ``|A (J v - reference)|`` (activation-weighted; equality rows weigh 1)."""
        return tuple(level.residual(self.v) for level in self.levels)

    @cached_property
    def activity(self) -> Mapping[str, bool]:
        """Per objective name, in priority order, whether it is active (:attr:`objectives`' ``active`` alone: what a
        recorder reads at every row, without the statuses' violations; from the objectives' rows when the solver
        gave them, without forming its levels)."""
        rows = (self._objective_rows() if self._objective_rows is not None
                else [rows for level in self.levels for rows in level.objectives])
        return {objective.name: self._active(objective) for objective in rows}

    def _active(self, rows: InequalityRows) -> bool:
        """Whether the objective of ``rows`` is active: some activation > 0, or (QP hierarchy) binding."""
        if self.binding is not None:
            return self.binding.get(rows.name, False)
        # (activation > 0).any() over the few rows as floats, without numpy's dispatch (NaN > 0 is False in both)
        return any(value > 0.0 for value in rows.activation.tolist())

    @cached_property
    def objectives(self) -> tuple[ObjectiveStatus, ...]:
        """The inequality objectives, in priority order: value, activation, whether active, violation."""
        return tuple(ObjectiveStatus(name=rows.name, level=level.index, value=rows.value, activation=rows.activation,
                                     active=self._active(rows), violation=rows.violation)
                     for level in self.levels for rows in level.objectives)

    @property
    def active(self) -> tuple[str, ...]:
        """Names of the active objectives."""
        return tuple(status.name for status in self.objectives if status.active)

    def status(self, name: str) -> ObjectiveStatus:
        """The status of the objective called ``name``.

        Raises:
            SolverInputError: no objective of that name (the message lists them).
        """
        for status in self.objectives:
            if status.name == name:
                return status
        raise SolverInputError(f"no objective {name!r} in this result; objectives: "
                               f"{', '.join(s.name for s in self.objectives) or 'none'}")
