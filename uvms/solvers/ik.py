"""Pose inverse kinematics: damped Newton (Levenberg-Marquardt) on the manifold, inside the joint limits.

The loop runs on a `PoseProblem` compiled once per call (targets, rows, the joint box
read once per Robot): one Pinocchio call per iteration (``computeFrameJacobian`` runs
the forward kinematics and gives the Jacobian of the next step), a Cholesky solve of the
small normal equations, limits by projection (a revolute joint first wraps by 2 pi), and
a start that stalls gives way to a random restart instead of using up its iterations.
"""

from __future__ import annotations

import math
import time
import weakref
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..errors import SolverInputError
from ..numerics.checks import check_count, check_scalar
from ..robot.kinematics import WORLD_ALIGNED
from ..robot.limits import Limit
from ..robot.robot import Robot, check_robot
from ..tasks.frame import FrameTask, log_pose_error
from .result import IKResult

Target = pin.SE3 | Sequence[float]
#: A start is abandoned (for a random restart) when its error has not shrunk below ``STALL_RATIO`` times the error
#: of ``STALL_ITERATIONS`` iterations earlier: a local minimum or a crawl along a joint limit.
STALL_ITERATIONS = 8
STALL_RATIO = 0.5
#: Levenberg-Marquardt damping d = mu |e|^2 + 1e-14 tr(J J^T) / k: the first mu of a start and its factors after an
#: accepted or a rejected step (swept on the UR5 benchmark, benchmarks/bench_ik.py).
MU_START, MU_DOWN, MU_UP = 0.1, 0.5, 10.0


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
    check_robot(robot, "solve_ik")
    targets = dict(target) if isinstance(target, Mapping) else {frame or robot.ee_frames[0]: target}
    missing = [name for name, pose in targets.items() if pose is None]
    if missing or not targets:
        raise SolverInputError(f"solve_ik needs a target pose for {', '.join(missing) or 'at least one frame'}: "
                               "a pin.SE3 or [x, y, z, roll, pitch, yaw]")
    tasks = [FrameTask(robot, name, axes=axes, target=pose) for name, pose in targets.items()]
    check_scalar(tolerance, "tolerance", positive=True)
    check_count(max_iterations, "max_iterations", minimum=1)
    check_count(restarts, "restarts")
    start = robot.neutral() if q_init is None else robot.check_configuration(q_init)
    problem = PoseProblem(robot, tasks)
    generator = None  # drawn from only when a restart is needed
    best_q, best_error, iterations = start, np.inf, 0
    for attempt in range(restarts + 1):
        if attempt:
            generator = np.random.default_rng(rng) if generator is None else generator
        q, error, used = newton(problem, start if attempt == 0 else random_start(robot, generator, best_q),
                                tolerance, max_iterations)
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


@dataclass(frozen=True)
class JointBox:
    """The joint position box of a robot in q coordinates, and a Pinocchio data of its own for the IK loop.

    Attributes:
        index: coordinates of q held by bounded-or-not scalar joints (b,).
        lower, upper: their limits (b,) [rad or m], +-inf where unbounded.
        turns: (b,) whether the coordinate is a revolute angle (2 pi periodic).
        data: ``model.createData()``, used by `PoseProblem.evaluate` only.
    """

    index: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    turns: np.ndarray
    data: pin.Data

    def __post_init__(self) -> None:
        from ..numerics._kernels.boxes import project_into_box  # numba: loaded by the IK, not by ``import uvms``

        object.__setattr__(self, "kernel", project_into_box)

    @classmethod
    def of(cls, robot: Robot) -> JointBox:
        """The box of ``robot`` (`Limit.joint_positions`), built once per Robot and kept while it lives."""
        box = BOXES.get(robot)
        if box is None:
            limit = Limit.joint_positions(robot)
            held = limit.q_index >= 0
            index = limit.q_index[held]
            revolute = revolute_coordinates(robot.model)
            box = cls(index.astype(np.int64), limit.lower[held].astype(float), limit.upper[held].astype(float),
                      np.array([i in revolute for i in index], dtype=bool), robot.model.createData())
            BOXES[robot] = box
        return box

    def project(self, q: np.ndarray) -> np.ndarray:
        """q (nq,) brought into the box in place; returns q.

        A revolute coordinate outside its limits first moves by a multiple of 2 pi when that
        lands inside (the same pose: Newton keeps its progress); what is still outside is clipped
        (:func:`~uvms.numerics._kernels.boxes.project_into_box`).
        """
        self.kernel(q, self.index, self.lower, self.upper, self.turns)
        return q


#: The `JointBox` of each live Robot (a Robot's joints and limits are fixed when it is loaded).
BOXES: weakref.WeakKeyDictionary[Robot, JointBox] = weakref.WeakKeyDictionary()


def revolute_coordinates(model: pin.Model) -> set[int]:
    """Indices in q of the 1-DOF revolute joints (about an axis of their frame or any axis), 2 pi periodic."""
    kinds = ("JointModelRX", "JointModelRY", "JointModelRZ", "JointModelRevoluteUnaligned")
    return {joint.idx_q for joint in model.joints[1:] if joint.nq == 1 and joint.shortname() in kinds}


class PoseProblem:
    """Pose targets compiled once for the Newton loop: one Pinocchio call per evaluation, no validation inside.

    The error is that of `FrameTask` with the "log" orientation, [t* - t; log3(R* R^T)]
    (world axes) on the task's rows, and the Jacobian its world-aligned frame Jacobian;
    one frame takes ``computeFrameJacobian`` (it runs the forward kinematics itself),
    several share one ``computeJointJacobians``.

    Args:
        robot: the model; tasks: frame tasks with targets (their "log" error is the one used).
    """

    def __init__(self, robot: Robot, tasks: Sequence[FrameTask]) -> None:
        self.model = robot.model
        self.box = JointBox.of(robot)
        self.data = self.box.data
        self.frame_ids = [task.frame_id for task in tasks]
        self.targets = [task.target for task in tasks]  # transform_target_to_world of each frame
        self.rows = [np.asarray(task.rows) for task in tasks]
        self.single = len(tasks) == 1 and len(self.rows[0]) == 6
        #: q (nq,) -> (stacked error (k,) [m, rad], Jacobian (k, nv), |error|), new arrays
        self.evaluate: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, float]] = (
            self._one_frame_evaluator() if self.single else self._evaluate_frames)

    def _evaluate_frames(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
        """Stacked error (k,) [m, rad], Jacobian (k, nv) and |error| of several frames (or rows) at q (nq,)."""
        model, data = self.model, self.data
        pin.computeJointJacobians(model, data, q)
        errors, jacobians = [], []
        for index, (frame, rows) in enumerate(zip(self.frame_ids, self.rows)):
            errors.append(self.pose_error(index, pin.updateFramePlacement(model, data, frame))[rows])
            jacobians.append(pin.getFrameJacobian(model, data, frame, WORLD_ALIGNED).reshape(6, model.nv)[rows])
        error = np.concatenate(errors)
        return error, np.vstack(jacobians), math.sqrt(error.dot(error))

    def _one_frame_evaluator(self) -> Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, float]]:
        """The evaluation of one frame of six rows (the common case), a closure over what it reads.

        The Newton loop calls it once per iteration, where each attribute lookup and call layer costs about
        as much as a Pinocchio call; the numbers are those of :meth:`pose_error` and the frame Jacobian.
        """
        from ..numerics._kernels.pose import (
            pose_error_norm as error_norm,  # numba: loaded by the IK, not by ``import uvms``
        )
        from ..numerics._kernels.pose import rotation_to_target as to_target

        model, data, frame, nv = self.model, self.data, self.frame_ids[0], self.model.nv
        placements, compute, log3 = data.oMf, pin.computeFrameJacobian, pin.log3
        target = self.targets[0]
        translation, rotation = np.ascontiguousarray(target.translation), np.ascontiguousarray(target.rotation)
        relative = np.empty((3, 3))  # R_d R^T, only read within a call

        def evaluate_one_frame(q: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
            jacobian = compute(model, data, q, frame, WORLD_ALIGNED)  # (6, nv); runs the forward kinematics
            pose = placements[frame].homogeneous  # transform_frame_to_world (4, 4)
            to_target(pose, rotation, relative)
            error = np.empty(6)
            norm = error_norm(pose, translation, log3(relative), error)
            return error, jacobian if nv > 1 else jacobian.reshape(6, nv), norm  # (6,) when nv = 1

        return evaluate_one_frame

    def pose_error(self, index: int, pose: pin.SE3) -> np.ndarray:
        """[t* - t; log3(R* R^T)] (6,) [m, rad] of a frame at ``pose`` against target ``index``."""
        target = self.targets[index]
        return log_pose_error(target.translation, target.rotation, pose)


def newton(problem: PoseProblem, q: np.ndarray, tolerance: float, max_iterations: int
           ) -> tuple[np.ndarray, float, int]:
    """Levenberg-Marquardt iterations from q, projected into the limits, until the error <= ``tolerance`` or a stall.

    Each step is the DLS solution J^T (J J^T + d I)^-1 e in normal-equation form
    (:func:`~uvms.numerics._kernels.dense.dls_solve_into`), d = mu |e|^2 + 1e-14 tr(J J^T) / k; mu
    shrinks after an accepted step and grows after a rejected one (``MU_*``). The
    candidate's evaluation gives its Jacobian too, so an accepted step costs one
    Pinocchio call. The start ends early when it stalls (``STALL_*``).

    Returns:
        (best q (nq,), its error norm [m, rad], iterations used).
    """
    from ..numerics._kernels.dense import dls_solve_into as solve  # numba: loaded by the IK, not by ``import uvms``

    model, box, evaluate = problem.model, problem.box, problem.evaluate
    q = box.project(np.array(q, dtype=float))
    error, jacobian, norm = evaluate(q)
    floor = 1e-14 * float(np.vdot(jacobian, jacobian)) / jacobian.shape[0]  # 1e-14 tr(J J^T) / k
    mu, checkpoint = MU_START, norm
    for iteration in range(1, max_iterations + 1):
        if norm <= tolerance:
            return q, norm, iteration - 1
        if iteration % STALL_ITERATIONS == 0:  # Newton near a solution gains far more than this: a stall
            if norm > STALL_RATIO * checkpoint:
                return q, norm, iteration - 1
            checkpoint = norm
        step = np.empty(model.nv)
        # not numerically positive definite (False): counts as a failed step
        if solve(jacobian, error, mu * norm * norm + floor, step):
            candidate = box.project(pin.integrate(model, q, step))
            candidate_error, candidate_jacobian, candidate_norm = evaluate(candidate)
            if candidate_norm < norm:  # False for NaN
                q, error, jacobian, norm = candidate, candidate_error, candidate_jacobian, candidate_norm
                mu = max(mu * MU_DOWN, 1e-12)
                continue
        mu *= MU_UP
        if mu > 1e8:
            break
    return q, norm, max_iterations
