"""Initial configuration of hoang2011 sec. 2.3: min S(q) subject to f(q) = x0 and the joint limits.

Solved with scipy's SLSQP over a flat chart of the configuration space
(vehicle position, roll-pitch-yaw / yaw, arm joints), then polished by Newton
steps on the constraint so the residual reaches the tolerance.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import pinocchio as pin
import scipy.optimize

from ..conventions import pose_from_xyyaw, pose_from_xyzrpy
from ..limits import Limit
from ..robot import Robot
from ..state import KinematicState
from ..tasks.joint_limits import JointLimitPotential
from ..tasks.task import Task
from .checks import check_count, check_scalar
from .inverses import pinv
from .results import InitialConfigurationResult
from .stack import as_task_list


def chart_of(robot: Robot, q: np.ndarray) -> np.ndarray:
    """Flat coordinates (nv,): [x, y, yaw] or [x, y, z, roll, pitch, yaw] of the vehicle, then the arm."""
    pose = robot.base_pose(q) * robot.model.jointPlacements[1].inverse() if robot.base_type != "fixed" else None
    arm = robot.arm_configuration(q)
    if robot.base_type == "floating":
        return np.concatenate([pose.translation, pin.rpy.matrixToRpy(pose.rotation), arm])
    if robot.base_type == "planar":
        yaw = np.arctan2(pose.rotation[1, 0], pose.rotation[0, 0])
        return np.concatenate([pose.translation[:2], [yaw], arm])
    return arm


def configuration_of(robot: Robot, chart: np.ndarray) -> np.ndarray:
    """q (nq,) from flat coordinates (the inverse of :func:`chart_of`)."""
    n = robot.n_vehicle
    if robot.base_type == "fixed":
        return robot.configuration(arm=chart)
    joint_motion = pose_from_xyzrpy(chart[:6]) if n == 6 else pose_from_xyyaw(chart[:3])
    return robot.configuration(base=robot.model.jointPlacements[1] * joint_motion, arm=chart[n:])


def chart_tangent(robot: Robot, chart: np.ndarray) -> np.ndarray:
    """d v / d chart (nv, nv): how a chart rate maps to Pinocchio's velocity v."""
    tangent = np.eye(robot.nv)
    if robot.base_type == "floating":
        rotation = pin.rpy.rpyToMatrix(*chart[3:6])
        tangent[:3, :3] = rotation.T  # local linear velocity
        tangent[3:6, 3:6] = pin.rpy.computeRpyJacobian(chart[3:6], pin.LOCAL)
    elif robot.base_type == "planar":
        c, s = np.cos(chart[2]), np.sin(chart[2])
        tangent[:2, :2] = [[c, s], [-s, c]]
    return tangent


def initial_configuration(
    robot: Robot,
    tasks: Task | Sequence[Task],
    potential: JointLimitPotential | None = None,
    q_init: np.ndarray | None = None,
    *,
    tolerance: float = 1e-10,
    max_iterations: int = 500,
    limit: Limit | None = None,
) -> InitialConfigurationResult:
    """q0 minimizing S(q) with the task(s) met exactly (e = 0) and the arm inside its limits.

    Args:
        robot: the model.
        tasks: task(s) whose targets define x0 (e.g. a FrameTask with axes x, y, yaw).
        potential: S(q); default JointLimitPotential(robot) with c_i = 1.
        q_init: starting guess (default: arm at mid-range, vehicle at the origin).
        tolerance: success when |e| <= tolerance.
        max_iterations: SLSQP iterations.
        limit: the arm position limits (n_arm,) kept by the optimizer (its bounds) and the
            polishing; default: those of ``potential``, the model's unless it was given others.
    """
    task_list = as_task_list(tasks)
    check_scalar(tolerance, "tolerance", positive=True)
    check_count(max_iterations, "max_iterations", minimum=1)
    potential = potential or JointLimitPotential(robot)
    if limit is None:
        limit = getattr(potential, "limit", None) or Limit.joint_positions(robot)
    if q_init is None:
        q_init = robot.configuration(arm=limit.middle)
    n = robot.n_vehicle
    bounds = limit.after_unbounded(n).bounds()  # the vehicle's chart coordinates are free

    def errors(chart):
        state = KinematicState(robot, configuration_of(robot, chart), check=False)
        return np.concatenate([task.error(state) for task in task_list]), state

    def constraint(chart):
        return errors(chart)[0]

    def constraint_jacobian(chart):
        state = errors(chart)[1]
        jacobian = np.vstack([task.jacobian(state) for task in task_list])
        return -jacobian @ chart_tangent(robot, chart)  # e = x0 - f(q)

    def objective(chart):
        return potential.value(configuration_of(robot, chart))

    def gradient(chart):
        full = np.zeros(robot.nv)
        full[n:] = potential.arm_gradient(chart[n:])
        return full

    start = chart_of(robot, robot.check_configuration(q_init))
    solution = scipy.optimize.minimize(
        objective, start, jac=gradient, method="SLSQP", bounds=bounds,
        constraints=[{"type": "eq", "fun": constraint, "jac": constraint_jacobian}],
        options={"maxiter": max_iterations, "ftol": 1e-14},
    )
    chart = polish(solution.x, constraint, constraint_jacobian, limit, n)
    residual = float(np.linalg.norm(constraint(chart)))
    q = configuration_of(robot, chart)
    inside = limit.contains(chart[n:])
    return InitialConfigurationResult(q=q, success=bool(residual <= tolerance and inside), residual=residual,
                                      potential=potential.value(q), iterations=int(solution.nit),
                                      message=str(solution.message))


def polish(
    chart: np.ndarray,
    constraint: Callable[[np.ndarray], np.ndarray],
    constraint_jacobian: Callable[[np.ndarray], np.ndarray],
    limit: Limit,
    n: int,
    steps: int = 20,
) -> np.ndarray:
    """Minimum-norm Newton corrections on e(chart) = 0 (chart (nv,)), the arm coordinates chart[n:] clamped into ``limit``."""
    chart = chart.copy()
    for _ in range(steps):
        error = constraint(chart)
        if np.linalg.norm(error) <= 1e-14:
            break
        chart = chart - pinv(constraint_jacobian(chart), rcond=1e-15) @ error  # numpy's default cut-off, as before
        chart[n:] = limit.clamp(chart[n:])
    return chart
