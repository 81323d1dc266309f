"""Closed-loop inverse kinematics (hoang2011 eq. 26-27, amundsen2018 eq. 7-8).

    v = J_W^+ (xdot_d + K e) + (I - J_W^+ J) z0,     z0 = -alpha grad S(q)

with J_W^+ the weighted pseudo-inverse, optionally damped (fixed damping or the
variable damping of amundsen2018 eq. 6), either with the ordinary Jacobian
(vehicle actuated) or with the generalized Jacobian (free-floating vehicle:
only the arm is commanded and the vehicle follows momentum conservation).

One frame task on an actuated vehicle is the common case (a pose or a point to follow): :class:`FrameStep`
solves it after Pinocchio's joint kinematics in one compiled call (its speed is measured by
``benchmarks/bench_clik.py``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
import pinocchio as pin

from ..errors import LimitError, NumericalError
from ..numerics.checks import check_damping, check_scalar, check_weights, free_floating_weights_note, prepared_gain
from ..numerics.inverses import (
    RCOND,
    SolverInputError,
    VariableDamping,
    WeightedInverse,
    damping_parameters,
    weights_subset,
)
from ..robot.configuration import Configuration
from ..robot.kinematics import base_velocity_from_momentum, support_columns
from ..robot.limits import Limit
from ..robot.robot import Robot, check_robot
from ..tasks.frame import FrameTask
from ..tasks.potential import MidRangePotential, NullspaceTerms
from ..tasks.task import Task, as_task_list
from .base import Solver, check_free_floating, checked_step
from .result import SolvedRows, SolverResult
from .stack import stacked_terms


class CLIKSolver(Solver):
    """The CLIK of a fixed task set (scenario method "clik"), its inputs checked and its pieces prepared once.

    The one implementation of CLIK: build it once, call :meth:`velocity` (or :meth:`step`) at every
    evaluation. What changes between calls is the configuration and the tasks' targets. One frame task on an
    actuated vehicle (or a fixed base), without joint clamping or mimic joints, is solved by a prepared step
    (:class:`FrameStep`: one compiled call after Pinocchio's joint kinematics, the general path's numbers);
    sigma_min (after a Cholesky solve) and the task's rows are then computed when read.

    Args:
        robot: the model.
        tasks: one task, several (stacked), or levels of tasks (stacked in order: CLIK has no priorities).
        gain: K, scalar, diagonal (k,) or (k, k) [1/s].
        weights: W, (n,) diagonal or (n, n) SPD, n = nv (or n_arm when free floating).
        damping: fixed lambda >= 0, or a VariableDamping (amundsen2018 eq. 6).
        potential: S(q) (a :class:`~uvms.tasks.potential.MidRangePotential`) whose gradient gives the null-space
            motion z0 = -alpha grad S.
        alpha: null-space gain alpha >= 0 [-].
        free_floating: use the generalized Jacobian; the vehicle is passive (follows momentum conservation).
        dt: step [s], needed by ``enforce_limits``.
        enforce_limits: keep q + dt v inside the arm limits by holding joints at their limits and re-solving
            the task with the others (joint clamping).
        limit: the arm position limits that ``enforce_limits`` keeps (n_arm,); default: the potential's when one
            is given, else ``Limit.joint_positions(robot)``, the model's (one source of bounds: the potential and
            the clamping read the same :class:`~uvms.robot.limits.Limit`).

    Raises:
        SolverInputError: a bad gain, weight, damping, alpha or dt, free_floating on a fixed base, or
            enforce_limits without dt.
        LimitError: enforce_limits with limits of another size or kind than the arm's positions, or other
            bounds than those of the potential.
    """

    name = "clik"
    holds_priorities = False  # levels are stacked: a given velocity is fixed columns, not a top level

    def __init__(
        self,
        robot: Robot,
        tasks: Task | Sequence[Task | Sequence[Task]],
        *,
        gain: float | np.ndarray = 1.0,
        weights: np.ndarray | None = None,
        damping: float | VariableDamping = 0.0,
        potential: MidRangePotential | None = None,
        alpha: float = 0.0,
        free_floating: bool = False,
        dt: float | None = None,
        enforce_limits: bool = False,
        limit: Limit | None = None,
    ) -> None:
        check_robot(robot, "CLIK")
        free_floating = check_free_floating(robot, free_floating)
        self.alpha = check_scalar(alpha, "alpha")
        self.robot, self.tasks, self.free_floating = robot, stacked_tasks(tasks), free_floating
        self.enforce_limits, self.dt = enforce_limits, dt
        if enforce_limits:
            if dt is None:
                raise SolverInputError("enforce_limits needs the step dt > 0")
            self.dt = check_scalar(dt, "dt", positive=True)
            limit = Limit.arm(robot, limit if limit is not None or potential is None else potential.limit,
                              "position", "enforce_limits")
            if potential is not None and not (np.array_equal(limit.lower, potential.limit.lower)
                                              and np.array_equal(limit.upper, potential.limit.upper)):
                raise LimitError("CLIK's joint clamping and its potential read one Limit: give it once (limit=, "
                                 "or the potential's limit=), not two different boxes")
        self.limit = limit
        # the solved coordinates joint clamping keeps: the (unbounded) vehicle unless free floating, then the arm
        self.first = robot.n_vehicle if free_floating else 0  # the first solved column of v
        self._clamp_limit = None if not enforce_limits else limit.after_unbounded(robot.n_vehicle - self.first)
        columns = robot.nv - self.first
        rows = sum(task.dim for task in self.tasks)
        ends = np.cumsum([task.dim for task in self.tasks])
        self._task_rows = [slice(end - task.dim, end) for task, end in zip(self.tasks, ends)]  # each task's rows
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
        self._frame_step = FrameStep(self, gain) if FrameStep.serves(self) else None

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

    def step(self, configuration: Configuration, dt: float) -> SolverResult:
        """Solve at ``configuration``, then move it along v for dt [s] (explicit Euler on the manifold, in place).

        Returns:
            The result at the configuration before the step.

        Raises:
            SolverInputError: dt not > 0, or not a Configuration of this solver's robot.
        """
        if self._frame_step is None:
            return super().step(configuration, dt)
        if not (dt.__class__ is float and 0.0 < dt < math.inf):  # a positive float passes without a call
            dt = checked_step(dt)
        frame_step = self._frame_step
        result = frame_step.solve(self._checked(configuration), dt)
        configuration.update(pin.integrate(configuration.model, configuration.q, frame_step.displacement), check=False)
        return result

    def stage_velocity(self, configuration: Configuration) -> np.ndarray:
        """v (nv,) of :meth:`velocity` alone (the prepared frame step's kernel without a result to build)."""
        if self._frame_step is not None:
            return self._frame_step.velocity(self._checked(configuration))
        return super().stage_velocity(configuration)

    def velocity(self, configuration: Configuration) -> SolverResult:
        """The CLIK velocity at ``configuration`` and its diagnostics (the residuals per task, when read)."""
        if self._frame_step is not None:
            return self._frame_step.solve(self._checked(configuration), 0.0)
        v, jacobian, error, command, sigma_min, used, held_names = self._solution(self._checked(configuration))
        if len(self.tasks) == 1:
            levels = (SolvedRows(0, jacobian, command, error),)
        else:
            levels = tuple(SolvedRows(index, jacobian[rows], command[rows], error[rows])
                           for index, rows in enumerate(self._task_rows))
        return SolverResult(v=v, sigma_min=sigma_min, damping=used, free_floating=self.free_floating,
                            limits_active=held_names, levels=levels)


def stacked_tasks(tasks: Task | Sequence[Task | Sequence[Task]]) -> list[Task]:
    """The tasks in stacking order: a task, a list of tasks, or a list of levels (each a task or a list)."""
    if isinstance(tasks, (list, tuple)) and not all(isinstance(task, Task) for task in tasks):
        return as_task_list([task for item in tasks for task in as_task_list(item)])
    return as_task_list(tasks)


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


#: The target angles of a frame task with the log orientation error (the kernel's "no Euler angles").
NO_ANGLES = np.zeros(0)


class FrameStep:
    """The prepared CLIK of one frame task (a :class:`CLIKSolver`'s fast path).

    After Pinocchio's joint kinematics (one ``computeJointJacobians`` per configuration,
    :meth:`Configuration.joint_arrays`), one compiled call (:func:`~uvms.numerics._kernels.clik.frame_clik_into`)
    computes the task's rows, the command, the null-space motion and the solution, in buffers laid out here once.
    sigma_min (after a Cholesky solve) and the task's rows are given to the result as functions: computed when read.

    Args:
        solver: the CLIKSolver, built and checked (:meth:`serves` it); gain: its K, checked.
    """

    def __init__(self, solver: CLIKSolver, gain: float | np.ndarray) -> None:
        from ..numerics._kernels.clik import frame_clik_into, weighted_sigma_min  # numba: loaded with the solver

        self._kernel, self._sigma_min = frame_clik_into, weighted_sigma_min
        self._weights = solver._inverse.kernel_weights  # (W^-1/2 (n,) or empty, L^-T (n, n) or empty)
        task: FrameTask = solver.tasks[0]
        model = solver.robot.model
        frame = model.frames[task.frame_id]
        self.task, self.joint, self.nv, self.count = task, int(frame.parentJoint), model.nv, task.dim
        self.indices, self.constants = frame_constants(solver, frame, gain)
        self.record_size = self.count * (self.nv + 2)  # the task's rows (k, nv), error (k,), command (k,)
        self.displacement = np.empty(self.nv)  # v dt of a step, read by pin.integrate at once (never kept)
        self._scratch = np.empty(self.record_size)  # the record of :meth:`velocity`, written and never read

    @staticmethod
    def serves(solver: CLIKSolver) -> bool:
        """Whether ``solver`` is one frame task on a robot without mimic joints, not free floating, without joint
        clamping: what :func:`~uvms.numerics._kernels.clik.frame_clik_into` computes."""
        tasks = solver.tasks
        return (len(tasks) == 1 and isinstance(tasks[0], FrameTask) and not solver.free_floating
                and not solver.enforce_limits and not solver.robot.mimic_joint_names)

    def solve(self, configuration: Configuration, dt: float) -> SolverResult:
        """The CLIK velocity at ``configuration`` (checked by the solver), sigma_min and the rows when read; with
        dt > 0 [s], v dt written to :attr:`displacement` (what ``pin.integrate`` adds in a step).

        Raises:
            UVMSError: the task has no target.
            NumericalError: a non-finite Jacobian (the SVD did not converge).
        """
        v, record = np.empty(self.nv), np.empty(self.record_size)
        sigma_min, used = self._into(configuration, dt, v, record)
        return SolverResult(v, (lambda: self._sigma_min(record, self.count, self.nv, *self._weights))
                            if sigma_min < 0.0 else sigma_min, used, lambda: self.levels(record))

    def velocity(self, configuration: Configuration) -> np.ndarray:
        """v (nv,) of :meth:`solve` at dt = 0 alone (an integrator's stage: no result, the rows in a scratch record
        no one reads).

        Raises:
            UVMSError, NumericalError: as :meth:`solve`.
        """
        v = np.empty(self.nv)
        self._into(configuration, 0.0, v, self._scratch)
        return v

    def _into(self, configuration: Configuration, dt: float, v: np.ndarray, record: np.ndarray) -> tuple[float, float]:
        """The kernel's call: v and the step's record written, (sigma_min (< 0: computed when read), l used)."""
        joint_jacobians, translation, rotation = configuration.joint_arrays(self.joint)
        target_translation, target_rotation, target_rpy, feedforward = self.task.target_terms()
        converged, sigma_min, used = self._kernel(joint_jacobians, translation, rotation, configuration.q,
                                                  target_translation, target_rotation,
                                                  NO_ANGLES if target_rpy is None else target_rpy, feedforward,
                                                  self.indices, self.constants, v, record, dt, self.displacement)
        if not converged:
            raise NumericalError(f"the SVD of the {self.count}x{self.nv} task Jacobian did not converge: is it finite?")
        return sigma_min, used

    def jacobian(self, record: np.ndarray) -> np.ndarray:
        """The task's rows (k, nv) in a step's record."""
        return record[:self.count * self.nv].reshape(self.count, self.nv)

    def levels(self, record: np.ndarray) -> tuple[SolvedRows, ...]:
        """The one level of a step's record: the task's rows, command and error."""
        size = self.count * self.nv
        return (SolvedRows(0, self.jacobian(record), record[size + self.count:], record[size:size + self.count]),)


def frame_constants(solver: CLIKSolver, frame: pin.Frame, gain: float | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(indices, constants): what a frame task's CLIK reads at every step and never changes, in the layout of
    :func:`~uvms.numerics._kernels.clik.frame_constants` (the task's rows and the columns moving its frame; the
    placement of the frame in its joint, K, the damping, W and the joint-limit potential's terms)."""
    task: FrameTask = solver.tasks[0]
    columns = support_columns(solver.robot.model, int(frame.parentJoint))
    terms = solver._nullspace if solver._nullspace is not None else NullspaceTerms.none()
    alpha = terms.alpha if solver._nullspace is not None else 0.0
    inverse_sqrt, transform = solver._inverse.kernel_weights
    kind = 1 if inverse_sqrt.size else 2 if transform.size else 0
    indices = np.concatenate([[task.dim, columns.size, terms.q_index.size, kind], task.rows, columns, terms.q_index,
                              terms.v_index]).astype(np.int64)
    gain = np.asarray(gain, dtype=float)  # checked by the solver: a scalar, a diagonal (k,) or (k, k)
    gain = gain if gain.ndim == 2 else np.diag(np.broadcast_to(gain, (task.dim,)))
    constants = np.concatenate([frame.placement.homogeneous.ravel(), gain.ravel(),
                                [*damping_parameters(solver.damping), RCOND, alpha], inverse_sqrt, transform.ravel(),
                                terms.weights, terms.middle, terms.range_squared]).astype(np.float64)
    return indices, constants
