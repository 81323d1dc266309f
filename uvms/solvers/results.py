"""Result objects of the solvers: the solution and its diagnostics, never bare arrays."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


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
    """One integration step of a velocity solver: the new configuration and the solution used."""

    q: np.ndarray
    velocity: VelocityResult


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
