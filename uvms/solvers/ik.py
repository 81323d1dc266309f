"""Pose inverse kinematics: damped Newton (Levenberg-Marquardt) on the manifold, inside the joint limits."""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence

import numpy as np
import pinocchio as pin

from ..errors import UVMSError
from ..robot import Robot
from ..state import KinematicState
from ..tasks.frame import FrameTask
from .results import IKResult

Target = pin.SE3 | Sequence[float]


def solve_ik(
    robot: Robot,
    target: Target | Mapping[str, Target],
    q_init: np.ndarray | None = None,
    frame: str | None = None,
    *,
    axes: Sequence[str] | None = None,
    tolerance: float = 1e-10,
    max_iterations: int = 100,
    restarts: int = 20,
    rng: np.random.Generator | int | None = 0,
) -> IKResult:
    """Configuration whose frame(s) reach the target pose(s), joints inside their limits.

    Args:
        robot: the model.
        target: a pose (``pin.SE3`` or [x, y, z, roll, pitch, yaw]) for ``frame``, or
            {frame: pose} for several end effectors at once.
        q_init: first guess (default: neutral); later starts are random.
        frame: frame of a single target (default: first end effector).
        axes: task axes (default: all six; x, y, yaw for a planar base).
        tolerance: success when the stacked error norm (position [m], log3 rotation [rad]) <= this.
        max_iterations: Newton iterations per start.
        restarts: random restarts after the first start.
        rng: seed or Generator of the restarts.

    Returns:
        IKResult; on failure ``success`` is False and ``q`` holds the best residual found.
    """
    started = time.perf_counter()
    targets = dict(target) if isinstance(target, Mapping) else {frame or robot.ee_frames[0]: target}
    tasks = [FrameTask(robot, name, axes=axes, target=pose) for name, pose in targets.items()]
    if not (np.isfinite(tolerance) and tolerance > 0 and max_iterations >= 1 and restarts >= 0):
        raise UVMSError("solve_ik needs tolerance > 0, max_iterations >= 1 and restarts >= 0")
    rng = np.random.default_rng(rng)
    start = robot.neutral() if q_init is None else robot.check_configuration(q_init)
    lower, upper = robot.model.lowerPositionLimit, robot.model.upperPositionLimit
    best_q, best_error, iterations = start, np.inf, 0
    for attempt in range(restarts + 1):
        q = project_to_limits(robot, start if attempt == 0 else random_start(robot, rng, best_q), lower, upper)
        q, error, used = newton(robot, q, tasks, tolerance, max_iterations, lower, upper)
        iterations += used
        if error < best_error:
            best_q, best_error = q, error
        if best_error <= tolerance:
            break
    return IKResult(q=best_q, success=bool(best_error <= tolerance), error=float(best_error), iterations=iterations,
                    restarts=attempt, time=time.perf_counter() - started)


def random_start(robot: Robot, rng: np.random.Generator, best_q: np.ndarray) -> np.ndarray:
    """Random arm joints; the vehicle starts from the best pose found so far."""
    q = robot.random_configuration(rng)
    q[: robot.nq_vehicle] = best_q[: robot.nq_vehicle]
    return q


def project_to_limits(robot: Robot, q: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """Clip the bounded arm coordinates of q into their limits."""
    q = q.copy()
    arm = slice(robot.nq_vehicle, robot.nq)
    q[arm] = np.clip(q[arm], lower[arm], upper[arm])
    return q


def newton(
    robot: Robot, q: np.ndarray, tasks: list[FrameTask], tolerance: float, max_iterations: int,
    lower: np.ndarray, upper: np.ndarray,
) -> tuple[np.ndarray, float, int]:
    """Levenberg-Marquardt iterations from q: damping shrinks on success, grows on failure."""
    def evaluate(configuration):
        state = KinematicState(robot, configuration, check=False)
        return state, np.concatenate([task.error(state) for task in tasks])

    state, error = evaluate(q)
    norm = float(np.linalg.norm(error))
    mu = 1e-3
    for iteration in range(1, max_iterations + 1):
        if norm <= tolerance:
            return q, norm, iteration - 1
        jacobian = np.vstack([task.jacobian(state) for task in tasks])  # (k, nv)
        normal = jacobian @ jacobian.T
        damping = mu * norm**2 + 1e-14 * np.trace(normal) / max(1, normal.shape[0])
        step = jacobian.T @ np.linalg.solve(normal + damping * np.eye(normal.shape[0]), error)
        candidate = project_to_limits(robot, pin.integrate(robot.model, q, step), lower, upper)
        candidate_state, candidate_error = evaluate(candidate)
        candidate_norm = float(np.linalg.norm(candidate_error))
        if np.isfinite(candidate_norm) and candidate_norm < norm:
            q, state, error, norm = candidate, candidate_state, candidate_error, candidate_norm
            mu = max(mu / 10.0, 1e-12)
        else:
            mu *= 10.0
            if mu > 1e8:
                break
    return q, norm, max_iterations
