"""Initial configuration of hoang2011 sec. 2.3: min S(q) subject to f(q) = x0 and the joint limits.

Solved with scipy's SLSQP over a flat chart of the configuration space
(vehicle position, roll-pitch-yaw / yaw, arm joints), then polished by Newton
steps on the constraint so the residual reaches the tolerance. Vehicle coordinates
named in ``fixed_base`` (e.g. roll and pitch) are left out of the optimization and
keep their given value exactly.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import pinocchio as pin

from ..errors import NameNotFound, SolverInputError
from ..numerics.checks import check_count, check_scalar
from ..numerics.inverses import pinv
from ..robot.configuration import Configuration
from ..robot.conventions import pose_from_xyyaw, pose_from_xyzrpy
from ..robot.limits import Limit
from ..robot.robot import Robot, check_robot
from ..tasks.potential import MidRangePotential
from ..tasks.task import Task
from .result import InitialConfigurationResult
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
    potential: MidRangePotential | None = None,
    q_init: np.ndarray | None = None,
    *,
    tolerance: float = 1e-10,
    max_iterations: int = 500,
    limit: Limit | None = None,
    fixed_base: Sequence[str] = (),
) -> InitialConfigurationResult:
    """q0 minimizing S(q) with the task(s) met exactly (e = 0) and the arm inside its limits.

    Args:
        robot: the model.
        tasks: task(s) whose targets define x0 (e.g. a FrameTask with axes x, y, yaw).
        potential: S(q); default MidRangePotential(robot) with c_i = 1.
        q_init: starting guess (default: arm at mid-range, vehicle at the origin).
        tolerance: success when ``|e| <= tolerance``.
        max_iterations: SLSQP iterations.
        limit: the arm position limits (n_arm,) kept by the optimizer (its bounds) and the
            polishing; default: those of ``potential``, the model's unless it was given others.
        fixed_base: vehicle coordinates held at their value in ``q_init`` (names of
            ``robot.base.pose_names``, e.g. ``("roll", "pitch")`` to keep the vehicle level);
            the others and the arm are optimized.

    Raises:
        SolverInputError: a bad tolerance or iteration count, fixed coordinates on a fixed base or on a
            vehicle joint placed with a rotation; NameNotFound: an unknown coordinate (close names listed).
    """
    check_robot(robot, "initial_configuration")
    task_list = as_task_list(tasks)
    check_scalar(tolerance, "tolerance", positive=True)
    check_count(max_iterations, "max_iterations", minimum=1)
    potential = potential or MidRangePotential(robot)
    limit = Limit.arm(robot, limit if limit is not None else potential.limit, "position", "initial_configuration")
    if q_init is None:
        q_init = robot.configuration(arm=limit.middle)
    n = robot.n_vehicle
    fixed = fixed_chart_indices(robot, fixed_base)
    free = np.setdiff1d(np.arange(robot.nv), fixed)  # the optimized chart coordinates, x = chart[free]
    bounds = limit.after_unbounded(n).bounds()  # the vehicle's chart coordinates are free
    start = chart_of(robot, robot.check_configuration(q_init))
    if fixed.size:
        bounds = [bounds[index] for index in free]

    def full(x):  # the chart (nv,) of the optimized coordinates x, the fixed ones at their start value
        if not fixed.size:
            return x
        chart = start.copy()
        chart[free] = x
        return chart

    def errors(x):
        state = Configuration(robot, configuration_of(robot, full(x)), check=False)
        return np.concatenate([task.error(state) for task in task_list]), state

    def constraint(x):
        return errors(x)[0]

    def constraint_jacobian(x):
        state = errors(x)[1]
        jacobian = np.vstack([task.jacobian(state) for task in task_list])
        derivative = -jacobian @ chart_tangent(robot, full(x))  # e = x0 - f(q)
        return derivative[:, free] if fixed.size else derivative

    def objective(x):
        return potential.value(configuration_of(robot, full(x)))

    def gradient(x):
        chart = full(x)
        whole = np.zeros(robot.nv)
        whole[n:] = potential.arm_gradient(chart[n:])
        return whole[free] if fixed.size else whole

    import scipy.optimize  # here, not at import: 0.2 s that `uvms info`, `view` and most runs do not need
    from threadpoolctl import threadpool_limits

    # SLSQP's numbers depend on how many BLAS threads share its sums (q0 moved by 1e-16 and a run by up to 3e-10
    # between 1 and 2 threads): on one thread, q0 is the same on every machine, in a sweep's or a Dask worker
    with threadpool_limits(limits=1, user_api="blas"):
        solution = scipy.optimize.minimize(
            objective, start[free] if fixed.size else start, jac=gradient, method="SLSQP", bounds=bounds,
            constraints=[{"type": "eq", "fun": constraint, "jac": constraint_jacobian}],
            options={"maxiter": max_iterations, "ftol": 1e-14},
        )
        free_vehicle = n - fixed.size  # the fixed coordinates are vehicle ones: x = [free vehicle, arm]
        x = polish(solution.x, constraint, constraint_jacobian, limit, free_vehicle)
    residual = float(np.linalg.norm(constraint(x)))
    chart = full(x)
    q = configuration_of(robot, chart)
    inside = limit.contains(chart[n:])
    return InitialConfigurationResult(q=q, success=bool(residual <= tolerance and inside), residual=residual,
                                      potential=potential.value(q), iterations=int(solution.nit),
                                      message=str(solution.message))


def fixed_chart_indices(robot: Robot, names: Sequence[str]) -> np.ndarray:
    """Chart indices (k,) of the vehicle coordinates ``names`` (``robot.base.pose_names``), sorted, no repeats."""
    if isinstance(names, str):
        names = [names]
    names = list(dict.fromkeys(names))
    if not names:
        return np.zeros(0, dtype=int)
    valid = list(robot.base.pose_names)
    if not valid:
        raise SolverInputError(f"{robot.name} has a fixed base: there is no vehicle coordinate to fix "
                               f"(got {', '.join(map(str, names))})")
    for name in names:
        if name not in valid:
            raise NameNotFound("vehicle coordinate", str(name), valid)
    if not np.allclose(robot.model.jointPlacements[1].rotation, np.eye(3), atol=1e-12):
        raise SolverInputError(f"fixing vehicle coordinates needs the vehicle joint of {robot.name} placed without "
                               f"a rotation (its chart then is the world pose)")
    return np.array(sorted(valid.index(name) for name in names), dtype=int)


def polish(
    chart: np.ndarray,
    constraint: Callable[[np.ndarray], np.ndarray],
    constraint_jacobian: Callable[[np.ndarray], np.ndarray],
    limit: Limit,
    n: int,
    steps: int = 20,
) -> np.ndarray:
    """Minimum-norm Newton corrections on e(chart) = 0, the arm coordinates chart[n:] clamped into ``limit``.

    ``chart`` holds the optimized coordinates: (nv,), or fewer when vehicle coordinates are fixed (then
    ``n`` counts the free vehicle coordinates only).
    """
    chart = chart.copy()
    for _ in range(steps):
        error = constraint(chart)
        if np.linalg.norm(error) <= 1e-14:
            break
        chart = chart - pinv(constraint_jacobian(chart), rcond=1e-15) @ error  # numpy's default cut-off, as before
        chart[n:] = limit.clamp(chart[n:])
    return chart
