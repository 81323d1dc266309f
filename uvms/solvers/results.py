"""Result objects of the solvers: the solution and its diagnostics, never bare arrays."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import SolverInputError


@dataclass(frozen=True)
class VelocityResult:
    """One differential-kinematics solution.

    Attributes:
        v: velocity (nv,) in the order of Pinocchio's v (vehicle twist local, then arm).
        command: task-space command xdot_d + K e (k,).
        error: task error e (k,) at the configuration.
        residual: |J v - command| (task rows not achieved, e.g. by damping or limits).
        sigma_min: smallest singular value of the (weighted) task Jacobian that was inverted.
        damping: damping factor lambda used (0: exact inverse).
        limits_active: names of the arm joints held at a limit in this solution.
        free_floating: whether the vehicle followed momentum conservation (generalized Jacobian).
    """

    v: np.ndarray
    command: np.ndarray
    error: np.ndarray
    residual: float
    sigma_min: float
    damping: float
    limits_active: tuple[str, ...] = ()
    free_floating: bool = False


@dataclass(frozen=True)
class StepResult:
    """One integration step of a velocity solver: the new configuration and the solution used
    (a :class:`VelocityResult`, or a :class:`SetBasedResult` / :class:`HQPResult` of the hierarchies)."""

    q: np.ndarray
    velocity: VelocityResult | SetBasedResult


@dataclass(frozen=True)
class PriorityResult:
    """A task-priority solution.

    Attributes:
        v: velocity (nv,).
        residuals: |J_i v - command_i| per level (priority order).
        sigma_min: smallest singular value of each level's inverted Jacobian.
        damping: damping factor used on every inversion.
        method: "classic" or "robust".
    """

    v: np.ndarray
    residuals: tuple[float, ...]
    sigma_min: tuple[float, ...]
    damping: float
    method: str


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
        residual: |x0 - f(q)|.
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


@dataclass(frozen=True)
class SetBasedResult:
    """A solution of a priority hierarchy of equality tasks and inequality objectives.

    Attributes:
        v: velocity (nv,) in the order of Pinocchio's v (vehicle twist local, then arm).
        objectives: the inequality objectives, in priority order, with their activations.
        command: task-space command xdot_d + K e (k,) of the equality tasks (all levels).
        error: task error e (k,) of the equality tasks.
        residual: |J v - command| over the equality tasks.
        level_residuals: per level, |A (J v - reference)| (activation-weighted; equality rows weigh 1).
            This and the other per-level fields cover the levels that hold rows, in order (a level holding
            only speed limits has none); ``ObjectiveStatus.level`` is the index in the levels given.
        sigma_min: smallest singular value of the (weighted, projected) Jacobian inverted for the last
            level that holds equality tasks (0 if none).
        scales: per level, the factor in [0, 1] its contribution was scaled by to meet the speed and
            position-rate bounds (1: not scaled; the lowest levels are scaled first).
        speed_ratio: max_i |v_i| / max_i over the speed limits given (0 without any).
        free_floating: whether only the arm was solved and the vehicle followed momentum conservation.
        damping: the largest damping lambda of the levels' inverses (0: exact inverses; the QP hierarchy: 0).
    """

    v: np.ndarray
    objectives: tuple[ObjectiveStatus, ...]
    command: np.ndarray
    error: np.ndarray
    residual: float
    level_residuals: tuple[float, ...]
    sigma_min: float
    scales: tuple[float, ...]
    speed_ratio: float
    free_floating: bool = False
    damping: float = 0.0

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


@dataclass(frozen=True)
class HQPResult(SetBasedResult):
    """A solution of the QP hierarchy: a :class:`SetBasedResult` plus the QPs' reports.

    Attributes:
        solver_status: per level, "optimal" or what happened instead (e.g. "failed: kept level 1"); a level
            that fails keeps the solution of the levels above, which meets every hard bound.
        slacks: per level, the norm of the optimal slack of its inequality rows (how far they were relaxed).
        solver: the QP solver used.
    """

    solver_status: tuple[str, ...] = ()
    slacks: tuple[float, ...] = ()
    solver: str = ""
