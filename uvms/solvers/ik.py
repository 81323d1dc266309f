"""Pose inverse kinematics: damped Newton (Levenberg-Marquardt) on the manifold, inside the joint limits."""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence

import numpy as np
import pinocchio as pin

from ..errors import SolverInputError
from ..limits import Limit
from ..robot import Robot
from ..state import KinematicState
from ..tasks.frame import FrameTask
from .checks import check_count, check_scalar
from .inverses import dls_solve
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
    check_scalar(tolerance, "tolerance", positive=True)
    check_count(max_iterations, "max_iterations", minimum=1)
    check_count(restarts, "restarts")
    rng = np.random.default_rng(rng)
    start = robot.neutral() if q_init is None else robot.check_configuration(q_init)
    limit = Limit.joint_positions(robot)
    best_q, best_error, iterations = start, np.inf, 0
    for attempt in range(restarts + 1):
        q = limit.project(start if attempt == 0 else random_start(robot, rng, best_q))
        q, error, used = newton(robot, q, tasks, tolerance, max_iterations, limit)
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


def project_to_limits(robot: Robot, q: np.ndarray, limit: Limit | None = None) -> np.ndarray:
    """q (nq,) with its bounded arm coordinates clipped into ``limit`` (default: the model's joint limits)."""
    return (Limit.joint_positions(robot) if limit is None else limit).project(q)


def newton(
    robot: Robot, q: np.ndarray, tasks: list[FrameTask], tolerance: float, max_iterations: int, limit: Limit,
) -> tuple[np.ndarray, float, int]:
    """Levenberg-Marquardt iterations from q, projected into ``limit``: damping shrinks on success, grows on failure.

    Each step is the DLS solution J^T (J J^T + d I)^-1 e in normal-equation form
    (:func:`~uvms.solvers.inverses.dls_solve`), d = mu |e|^2 + 1e-14 tr(J J^T) / k.
    """
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
        damping = mu * norm**2 + 1e-14 * np.sum(jacobian**2) / max(1, jacobian.shape[0])  # tr(J J^T) = |J|_F^2
        try:
            step = dls_solve(jacobian, error, damping)
        except SolverInputError:  # not numerically positive definite: counts as a failed step
            step = None
        if step is not None:
            candidate = limit.project(pin.integrate(robot.model, q, step))
            candidate_state, candidate_error = evaluate(candidate)
            candidate_norm = float(np.linalg.norm(candidate_error))
            if np.isfinite(candidate_norm) and candidate_norm < norm:
                q, state, error, norm = candidate, candidate_state, candidate_error, candidate_norm
                mu = max(mu / 10.0, 1e-12)
                continue
        mu *= 10.0
        if mu > 1e8:
            break
    return q, norm, max_iterations
