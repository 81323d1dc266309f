"""Closed-loop inverse kinematics (hoang2011 eq. 26-27, amundsen2018 eq. 7-8).

    v = J_W^+ (xdot_d + K e) + (I - J_W^+ J) z0,     z0 = -alpha grad S(q)

with J_W^+ the weighted pseudo-inverse, optionally damped (fixed damping or the
variable damping of amundsen2018 eq. 6), either with the ordinary Jacobian
(vehicle actuated) or with the generalized Jacobian (free-floating vehicle:
only the arm is commanded and the vehicle follows momentum conservation).
"""

from __future__ import annotations

from collections.abc import Sequence
import numpy as np
import pinocchio as pin

from ..kinematics import base_velocity_from_momentum
from ..limits import Limit
from ..robot import Robot
from ..state import KinematicState
from ..tasks.joint_limits import JointLimitPotential
from ..tasks.task import Task
from .checks import check_scalar, check_weights, free_floating_weights_note
from .inverses import SolverInputError, VariableDamping, damped_weighted_inverse, svd_inverse, weights_subset
from .results import StepResult, VelocityResult
from .stack import as_task_list, stack

# VariableDamping, damped_weighted_inverse and svd_inverse live in .inverses and stay importable from here.
__all__ = ["VariableDamping", "clik_step", "clik_velocity", "damped_weighted_inverse", "solve_with_held",
           "svd_inverse"]


def clik_velocity(
    robot: Robot,
    q: np.ndarray | KinematicState,
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
    """One CLIK velocity.

    Args:
        robot: the model.
        q: configuration (nq,) or a KinematicState already computed at it.
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
    if free_floating and robot.base_type == "fixed":
        raise SolverInputError(f"{robot.name} has a fixed base: free_floating=True needs a floating or planar base")
    check_scalar(alpha, "alpha")
    if enforce_limits:
        if dt is None:
            raise SolverInputError("enforce_limits needs the step dt > 0")
        check_scalar(dt, "dt", positive=True)
        limit = Limit.joint_positions(robot) if limit is None else limit
        if limit.size != robot.n_arm or limit.kind != "position":
            raise SolverInputError(f"enforce_limits needs position limits of the {robot.n_arm} arm coordinates, "
                                   f"got {limit.size} {limit.kind} limits")
    state = q if isinstance(q, KinematicState) else KinematicState(robot, q)
    jacobian, error, command = stack(state, as_task_list(tasks), gain)  # (k, nv), (k,), (k,)
    first = robot.n_vehicle if free_floating else 0
    solved_jacobian = state.generalized(jacobian) if free_floating else jacobian  # (k, n)
    if weights is not None:
        weights = check_weights(weights, solved_jacobian.shape[1], "W",
                                free_floating_weights_note(robot.n_arm) if free_floating else "")
    nullspace_motion = None
    if potential is not None and alpha > 0:  # -alpha dS/dv on the solved columns (S has no vehicle entries)
        gradient = np.zeros(robot.nv)
        gradient[robot.n_vehicle:] = potential.arm_gradient(robot.arm_values(state.q))
        nullspace_motion = -alpha * gradient[first:]
    free = np.arange(solved_jacobian.shape[1])
    held: dict[int, float] = {}
    if enforce_limits:  # the solved coordinates: arm joints, and the (unbounded) vehicle unless free floating
        limit = limit.after_unbounded(robot.n_vehicle - first)
        now = np.concatenate([np.zeros(robot.n_vehicle - first), robot.arm_values(state.q)])
    for _ in range(solved_jacobian.shape[1] + 1):
        solution, sigma_min, used = solve_with_held(
            solved_jacobian, command, weights, damping, nullspace_motion, free, held)
        if not enforce_limits:
            break
        predicted = now + dt * solution
        violated = limit.violated(predicted)
        outside = [i for i in free if violated[i]]
        if not outside:
            break
        bounds = limit.crossed_bound(predicted)
        for index in outside:  # hold the joint where the step reaches its limit
            held[index] = (bounds[index] - now[index]) / dt
        free = np.array([i for i in free if i not in held], dtype=int)
    v = np.zeros(robot.nv)
    v[first:] = solution
    if free_floating:
        a_base, a_arm = state.centroidal_split()
        v[:first] = base_velocity_from_momentum(a_base, a_arm, solution, None)
    residual = float(np.linalg.norm(jacobian @ v - command))
    held_names = tuple(limit.names[index] for index in sorted(held)) if held else ()
    return VelocityResult(v=v, command=command, error=error, residual=residual, sigma_min=sigma_min,
                          damping=used, limits_active=held_names, free_floating=free_floating)


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
    free_jacobian = jacobian[:, free]
    every = free.size == jacobian.shape[1]  # no joint held: W as checked by the caller
    free_weights = weights if weights is None or every else weights_subset(weights, free, jacobian.shape[1])
    inverse, sigma_min, used = damped_weighted_inverse(free_jacobian, free_weights, damping)
    solution[free] = inverse @ remaining
    if nullspace_motion is not None:
        z0 = nullspace_motion[free]
        solution[free] += z0 - inverse @ (free_jacobian @ z0)
    return solution, sigma_min, used


def clik_step(robot: Robot, q: np.ndarray, tasks: Task | Sequence[Task], dt: float, **options) -> StepResult:
    """One explicit-Euler CLIK step on the configuration manifold: q+ = integrate(q, v dt).

    ``options`` are those of :func:`clik_velocity`.
    """
    check_scalar(dt, "dt", positive=True)
    velocity = clik_velocity(robot, q, tasks, dt=dt, **options)
    return StepResult(q=pin.integrate(robot.model, np.asarray(q, dtype=float), velocity.v * dt), velocity=velocity)
