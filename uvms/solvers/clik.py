"""Closed-loop inverse kinematics (hoang2011 eq. 26-27, amundsen2018 eq. 7-8).

    v = J_W^+ (xdot_d + K e) + (I - J_W^+ J) z0,     z0 = -alpha grad S(q)

with J_W^+ the weighted pseudo-inverse, optionally damped (fixed damping or the
variable damping of amundsen2018 eq. 6), either with the ordinary Jacobian
(vehicle actuated) or with the generalized Jacobian (free-floating vehicle:
only the arm is commanded and the vehicle follows momentum conservation).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
import pinocchio as pin

from ..robot.kinematics import base_velocity_from_momentum
from ..robot.limits import Limit
from ..robot.robot import Robot, check_robot
from ..robot.configuration import Configuration
from ..tasks.joint_limits import JointLimitPotential
from ..tasks.task import Task
from ..tasks.task import as_task_list
from ..numerics.checks import (check_damping, check_scalar, check_weights, free_floating_weights_note,
                     prepared_gain)
from ..numerics.inverses import (SolverInputError, VariableDamping, WeightedInverse, damped_weighted_inverse, svd_inverse,
                       weights_subset)
from .results import StepResult, VelocityResult
from .stack import stacked_terms

# VariableDamping, damped_weighted_inverse and svd_inverse live in .inverses and stay importable from here.
__all__ = ["CLIKSolver", "VariableDamping", "clik_step", "clik_velocity", "damped_weighted_inverse", "solve_with_held",
           "svd_inverse"]


class CLIKSolver:
    """The CLIK of a fixed task set, its inputs checked and its pieces prepared once.

    The one implementation of CLIK: :func:`clik_velocity` builds one and solves once; a controller builds
    one and calls :meth:`solve` (or :meth:`velocity`, without diagnostics) at every evaluation, with the same
    numbers, bit for bit. What changes between calls is the configuration and the tasks' targets.

    Args: those of :func:`clik_velocity` (after ``q``).
    """

    def __init__(
        self,
        robot: Robot,
        tasks: Task | Sequence[Task],
        *,
        gain: float | np.ndarray = 1.0,
        weights: np.ndarray | None = None,
        damping: float | VariableDamping = 0.0,
        potential: JointLimitPotential | None = None,
        alpha: float = 0.0,
        free_floating: bool = False,
        dt: float | None = None,
        enforce_limits: bool = False,
        limit: Limit | None = None,
    ) -> None:
        check_robot(robot, "CLIK")
        if free_floating and robot.base_type == "fixed":
            raise SolverInputError(f"{robot.name} has a fixed base: free_floating=True needs a floating or planar base")
        self.alpha = check_scalar(alpha, "alpha")
        self.robot, self.tasks, self.free_floating = robot, as_task_list(tasks), free_floating
        self.enforce_limits, self.dt = enforce_limits, dt
        if enforce_limits:
            if dt is None:
                raise SolverInputError("enforce_limits needs the step dt > 0")
            self.dt = check_scalar(dt, "dt", positive=True)
            limit = Limit.joint_positions(robot) if limit is None else limit
            if limit.size != robot.n_arm or limit.kind != "position":
                raise SolverInputError(f"enforce_limits needs position limits of the {robot.n_arm} arm coordinates, "
                                       f"got {limit.size} {limit.kind} limits")
        self.limit = limit
        # the solved coordinates joint clamping keeps: the (unbounded) vehicle unless free floating, then the arm
        self.first = robot.n_vehicle if free_floating else 0  # the first solved column of v
        self._clamp_limit = None if not enforce_limits else limit.after_unbounded(robot.n_vehicle - self.first)
        columns = robot.nv - self.first
        rows = sum(task.dim for task in self.tasks)
        # refuses a bad gain now, with its message, rather than at every call
        self._command: Callable[[np.ndarray, np.ndarray], np.ndarray] = prepared_gain(gain, rows)
        self.weights = None if weights is None else check_weights(
            weights, columns, "W", free_floating_weights_note(robot.n_arm) if free_floating else "")
        self._inverse = WeightedInverse(self.weights, columns)  # (J (k, n), damping) -> inverse, sigma_min, used
        self.damping = damping if isinstance(damping, VariableDamping) else check_damping(damping)
        self.potential = potential if potential is not None and self.alpha > 0 else None
        # the potential's arrays, read once, for the compiled z0 (numba: loaded here, not by ``import uvms``)
        self._nullspace = None if self.potential is None else self.potential.nullspace_terms(self.alpha, self.first)
        from ..numerics._kernels.clik import joint_limit_motion_into

        self._joint_limit_motion = joint_limit_motion_into

    def _nullspace_motion(self, q: np.ndarray) -> np.ndarray | None:
        """z0 = -alpha dS/dv on the solved columns (S has no vehicle entries), or None."""
        if self._nullspace is None:
            return None
        z0 = np.empty(self.robot.nv - self.first)
        self._joint_limit_motion(q, *self._nullspace, z0)
        return z0

    def _solution(self, state: Configuration) -> tuple:
        """(v (nv,), task Jacobian (k, nv), error (k,), command (k,), sigma_min, damping used, held names)."""
        robot = self.robot
        jacobian, error, feedforward = stacked_terms(state, self.tasks)  # (k, nv), (k,), (k,)
        command = self._command(error, feedforward)
        solved = state.generalized(jacobian) if self.free_floating else jacobian  # (k, n)
        nullspace_motion = self._nullspace_motion(state.q)
        held: dict[int, float] = {}
        if self.enforce_limits:
            solution, sigma_min, used, held = self._clamped(state, solved, command, nullspace_motion)
        else:
            solution, sigma_min, used = self._inverse.solve(solved, command, self.damping, nullspace_motion)
        v = np.zeros(robot.nv)
        v[self.first:] = solution
        if self.free_floating:
            a_base, a_arm = state.centroidal_split()
            v[:self.first] = base_velocity_from_momentum(a_base, a_arm, solution, None)
        held_names = tuple(self._clamp_limit.names[index] for index in sorted(held)) if held else ()
        return v, jacobian, error, command, sigma_min, used, held_names

    def _clamped(self, state: Configuration, jacobian: np.ndarray, command: np.ndarray,
                 nullspace_motion: np.ndarray | None) -> tuple[np.ndarray, float, float, dict[int, float]]:
        """Joint clamping: hold the joints the step would carry past a limit at it and solve with the others."""
        robot, dt, limit = self.robot, self.dt, self._clamp_limit
        now = np.concatenate([np.zeros(robot.n_vehicle - self.first), robot.arm_values(state.q)])
        free = np.arange(jacobian.shape[1])
        held: dict[int, float] = {}
        for _ in range(jacobian.shape[1] + 1):
            solution, sigma_min, used = solve_with_held(jacobian, command, self.weights, self.damping,
                                                        nullspace_motion, free, held)
            predicted = now + dt * solution
            violated = limit.violated(predicted)
            outside = [i for i in free if violated[i]]
            if not outside:
                break
            bounds = limit.crossed_bound(predicted)
            for index in outside:  # hold the joint where the step reaches its limit
                held[index] = (bounds[index] - now[index]) / dt
            free = np.array([i for i in free if i not in held], dtype=int)
        return solution, sigma_min, used, held

    def _state(self, q: np.ndarray | Configuration, check: bool) -> Configuration:
        return q if isinstance(q, Configuration) else Configuration(self.robot, q, check=check)

    def solve(self, q: np.ndarray | Configuration, *, check: bool = True) -> VelocityResult:
        """The CLIK velocity at q and its diagnostics.

        Args:
            q: configuration (nq,) or a Configuration already computed at it.
            check: validate an array q (False for configurations of ``pin.integrate`` in a loop).
        """
        v, jacobian, error, command, sigma_min, used, held_names = self._solution(self._state(q, check))
        residual = jacobian @ v - command
        return VelocityResult(v=v, command=command, error=error, residual=math.sqrt(residual.dot(residual)),
                              sigma_min=sigma_min, damping=used, limits_active=held_names,
                              free_floating=self.free_floating)

    def velocity(self, q: np.ndarray | Configuration, *, check: bool = True) -> np.ndarray:
        """The CLIK velocity v (nv,) at q alone (the stages of an integrator, where no one reads diagnostics)."""
        return self._solution(self._state(q, check))[0]


def clik_velocity(
    robot: Robot,
    q: np.ndarray | Configuration,
    tasks: Task | Sequence[Task],
    *,
    gain: float | np.ndarray = 1.0,
    weights: np.ndarray | None = None,
    damping: float | VariableDamping = 0.0,
    potential: JointLimitPotential | None = None,
    alpha: float = 0.0,
    free_floating: bool = False,
    dt: float | None = None,
    enforce_limits: bool = False,
    limit: Limit | None = None,
) -> VelocityResult:
    """One CLIK velocity, from a :class:`CLIKSolver` built for this call.

    Every call checks its inputs and builds a new solver (nothing is kept between calls), so it always reads
    the current values of its arguments. A loop should build ``CLIKSolver(robot, tasks, ...)`` once and call
    its :meth:`~CLIKSolver.solve` at every step: the same numbers, without the checks and preparation.

    Args:
        robot: the model.
        q: configuration (nq,) or a Configuration already computed at it.
        tasks: one task or several (stacked).
        gain: K, scalar, diagonal (k,) or (k, k).
        weights: W, (n,) diagonal or (n, n) SPD, n = nv (or n_arm when free floating).
        damping: fixed lambda >= 0, or a VariableDamping.
        potential: S(q) whose gradient gives the null-space motion z0 = -alpha grad S.
        alpha: null-space gain alpha >= 0.
        free_floating: use the generalized Jacobian; the vehicle is passive.
        dt: step [s], needed by ``enforce_limits``.
        enforce_limits: keep q + dt v inside the arm limits by holding joints at their
            limits and re-solving the task with the others (joint clamping).
        limit: the arm position limits that ``enforce_limits`` keeps (n_arm,); default
            ``Limit.joint_positions(robot)``, the model's.

    Returns:
        VelocityResult with the full velocity v (nv,).
    """
    solver = CLIKSolver(robot, tasks, gain=gain, weights=weights, damping=damping, potential=potential, alpha=alpha,
                        free_floating=free_floating, dt=dt, enforce_limits=enforce_limits, limit=limit)
    return solver.solve(q)


def solve_with_held(
    jacobian: np.ndarray,
    command: np.ndarray,
    weights: np.ndarray | None,
    damping: float | VariableDamping,
    nullspace_motion: np.ndarray | None,
    free: np.ndarray,
    held: dict[int, float],
) -> tuple[np.ndarray, float, float]:
    """Solve J x = command for the free columns, the held ones fixed; add the null-space motion."""
    solution = np.zeros(jacobian.shape[1])
    for index, value in held.items():
        solution[index] = value
    if free.size == 0:  # every joint held at its limit: nothing left to solve
        singular_values = np.linalg.svd(jacobian, compute_uv=False)
        return solution, float(singular_values.min(initial=0.0)), 0.0
    remaining = command - jacobian @ solution
    every = free.size == jacobian.shape[1]  # no joint held: W as checked by the caller
    free_weights = weights if weights is None or every else weights_subset(weights, free, jacobian.shape[1])
    checked = damping if isinstance(damping, VariableDamping) else check_damping(damping)
    z0 = None if nullspace_motion is None else nullspace_motion[free]
    solution[free], sigma_min, used = WeightedInverse(free_weights, free.size).solve(jacobian[:, free], remaining,
                                                                                     checked, z0)
    return solution, sigma_min, used


def clik_step(robot: Robot, q: np.ndarray, tasks: Task | Sequence[Task], dt: float, **options) -> StepResult:
    """One explicit-Euler CLIK step on the configuration manifold: q+ = integrate(q, v dt).

    Like :func:`clik_velocity`, every call checks its inputs and builds a new :class:`CLIKSolver`; a loop
    should build one solver once and step with it. ``options`` are those of :func:`clik_velocity`.
    """
    check_scalar(dt, "dt", positive=True)
    velocity = clik_velocity(robot, q, tasks, dt=dt, **options)
    return StepResult(q=pin.integrate(robot.model, np.asarray(q, dtype=float), velocity.v * dt), velocity=velocity)
