"""Closed-loop inverse kinematics (hoang2011 eq. 26-27, amundsen2018 eq. 7-8).

    v = J_W^+ (xdot_d + K e) + (I - J_W^+ J) z0,     z0 = -alpha grad S(q)

with J_W^+ the weighted pseudo-inverse, optionally damped (fixed damping or the
variable damping of amundsen2018 eq. 6), either with the ordinary Jacobian
(vehicle actuated) or with the generalized Jacobian (free-floating vehicle:
only the arm is commanded and the vehicle follows momentum conservation).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..kinematics import base_velocity_from_momentum
from ..robot import Robot
from ..state import KinematicState
from ..tasks.joint_limits import JointLimitPotential
from ..tasks.task import Task
from .inverses import RCOND, SolverInputError, check_damping, variable_damping, weights_factor
from .results import StepResult, VelocityResult
from .stack import as_task_list, stack


@dataclass(frozen=True)
class VariableDamping:
    """Damping of amundsen2018 eq. 6: l^2 = (1 - (s_min/epsilon)^2) lambda_max^2 when s_min < epsilon."""

    epsilon: float
    lambda_max: float

    def __call__(self, sigma_min: float) -> float:
        return variable_damping(sigma_min, self.epsilon, self.lambda_max)


def damped_weighted_inverse(
    jacobian: np.ndarray, weights: np.ndarray | None, damping: float | VariableDamping
) -> tuple[np.ndarray, float, float]:
    """Inverse of J weighted by W and damped: L^-T dls(J L^-T, l), W = L L^T.

    With W = I and l = 0 this is the pseudo-inverse; with l = 0 the weighted
    pseudo-inverse of hoang2011 eq. 15; with W = I the DLS of amundsen2018 eq. 4-5.

    Returns:
        (inverse (n, k), sigma_min of the weighted Jacobian, damping used).
    """
    factor = None if weights is None else weights_factor(weights, jacobian.shape[1])
    scaled = jacobian if factor is None else factor.scale(jacobian)
    inverse, sigma_min, value = svd_inverse(scaled, damping)
    if factor is not None:
        inverse = factor.unscale(inverse)
    return inverse, sigma_min, value


def svd_inverse(jacobian: np.ndarray, damping: float | VariableDamping) -> tuple[np.ndarray, float, float]:
    """DLS inverse V diag(s / (s^2 + l^2)) U^T from one SVD, which also gives sigma_min and the variable damping.

    With l = 0, singular values below RCOND * s_max count as zero (the pseudo-inverse).
    """
    u, singular, vt = np.linalg.svd(jacobian, full_matrices=False)
    sigma_min = float(singular[-1]) if jacobian.shape[0] <= jacobian.shape[1] and singular.size else 0.0
    value = damping(sigma_min) if isinstance(damping, VariableDamping) else check_damping(damping)
    if value > 0.0:
        factors = singular / (singular**2 + value**2)
    else:
        cutoff = RCOND * (singular[0] if singular.size else 0.0)
        factors = np.divide(1.0, singular, out=np.zeros_like(singular), where=singular > cutoff)
    return (vt.T * factors) @ u.T, sigma_min, value


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

    Returns:
        VelocityResult with the full velocity v (nv,).
    """
    state = q if isinstance(q, KinematicState) else KinematicState(robot, q)
    jacobian, error, command = stack(state, as_task_list(tasks), gain)
    first = robot.n_vehicle if free_floating else 0
    solved_jacobian = state.generalized(jacobian) if free_floating else jacobian  # (k, n)
    if free_floating and robot.base_type == "fixed":
        raise SolverInputError(f"{robot.name} has a fixed base: free_floating=True needs a floating or planar base")
    if not np.isfinite(alpha) or alpha < 0:
        raise SolverInputError(f"alpha must be finite and >= 0, got {alpha!r}")
    nullspace_motion = None
    if potential is not None and alpha > 0:
        nullspace_motion = -alpha * potential.gradient(state.q)[first:]
    free = np.arange(solved_jacobian.shape[1])
    held: dict[int, float] = {}
    if enforce_limits:
        if dt is None or dt <= 0:
            raise SolverInputError("enforce_limits needs the step dt > 0")
        lower, upper, arm_now = limits_in_solved_coordinates(robot, state.q, first)
    for _ in range(solved_jacobian.shape[1] + 1):
        solution, sigma_min, used = solve_with_held(
            solved_jacobian, command, weights, damping, nullspace_motion, free, held)
        if not enforce_limits:
            break
        predicted = arm_now + dt * solution
        outside = [i for i in free if predicted[i] < lower[i] - 1e-12 or predicted[i] > upper[i] + 1e-12]
        if not outside:
            break
        for index in outside:
            bound = lower[index] if predicted[index] < lower[index] else upper[index]
            held[index] = (bound - arm_now[index]) / dt
        free = np.array([i for i in free if i not in held])
    v = np.zeros(robot.nv)
    v[first:] = solution
    if free_floating:
        a_base, a_arm = state.centroidal_split()
        v[:first] = base_velocity_from_momentum(a_base, a_arm, solution, None)
    residual = float(np.linalg.norm(jacobian @ v - command))
    held_names = tuple(joint_name_of_column(robot, first + index) for index in sorted(held))
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
    remaining = command - jacobian @ solution
    free_jacobian = jacobian[:, free]
    free_weights = None if weights is None else submatrix(weights, free, jacobian.shape[1])
    inverse, sigma_min, used = damped_weighted_inverse(free_jacobian, free_weights, damping)
    solution[free] = inverse @ remaining
    if nullspace_motion is not None:
        z0 = nullspace_motion[free]
        solution[free] += z0 - inverse @ (free_jacobian @ z0)
    return solution, sigma_min, used


def submatrix(weights: np.ndarray, indices: np.ndarray, size: int) -> np.ndarray:
    """Rows/columns ``indices`` of W given as (n,) diagonal or (n, n)."""
    weights = np.asarray(weights, dtype=float)
    if weights.ndim == 1:
        if weights.shape != (size,):
            raise SolverInputError(f"W must be ({size},) or ({size}, {size}), got shape {weights.shape}")
        return weights[indices]
    if weights.shape != (size, size):
        raise SolverInputError(f"W must be ({size},) or ({size}, {size}), got shape {weights.shape}")
    return weights[np.ix_(indices, indices)]


def limits_in_solved_coordinates(robot: Robot, q: np.ndarray, first: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Lower, upper and current values of the solved velocity coordinates (vehicle: unbounded)."""
    lower, upper = robot.arm_limits
    arm = robot.arm_configuration(q)
    vehicle = robot.n_vehicle - first
    unbounded = np.full(vehicle, np.inf)
    return (np.concatenate([-unbounded, lower]), np.concatenate([unbounded, upper]),
            np.concatenate([np.zeros(vehicle), arm]))


def joint_name_of_column(robot: Robot, column: int) -> str:
    """Name of the joint that owns velocity column ``column``."""
    for joint in robot.joints:
        if joint.idx_v <= column < joint.idx_v + joint.nv:
            return joint.name
    raise IndexError(column)


def clik_step(robot: Robot, q: np.ndarray, tasks: Task | Sequence[Task], dt: float, **options) -> StepResult:
    """One explicit-Euler CLIK step on the configuration manifold: q+ = integrate(q, v dt).

    ``options`` are those of :func:`clik_velocity`.
    """
    if not np.isfinite(dt) or dt <= 0:
        raise SolverInputError(f"dt must be finite and > 0, got {dt!r}")
    velocity = clik_velocity(robot, q, tasks, dt=dt, **options)
    return StepResult(q=pin.integrate(robot.model, np.asarray(q, dtype=float), velocity.v * dt), velocity=velocity)
