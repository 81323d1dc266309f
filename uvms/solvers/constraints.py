"""Kinematic constraints (santos2006): impose some velocity magnitudes, solve the others exactly.

The constraint tasks C v = d (e.g. vehicle u = v = 0 and a yaw rate that turns
the vehicle toward the current) and the end-effector task J v = xdot are
solved together as one system [C; J] v = [d; xdot]: exactly when it is square
and regular — the Davies-method solution N_s Y_s = -N_p Y_p of the paper
(see :mod:`uvms.solvers.screws`) — and in the least-squares sense otherwise,
with the residual reported. With ``free_floating`` both are their generalized
forms (only the arm is solved; the vehicle follows momentum conservation).

Bounded command (the paper's method has none): away from singularities the solution above is kept as it is;
where [C; J] loses rank (sigma_min below :data:`SINGULAR_DAMPING`'s epsilon) the task rows are inverted in the
constraints' null space with the variable damping of amundsen2018 eq. 6. Given the step dt (a run that integrates
the command; without it :meth:`ConstraintSolver.velocity` keeps the paper's solution), the task's part of v is
scaled into the model's joint speed limits (``<limit velocity>``) and the position-rate bounds of its joint limits
(:mod:`uvms.solvers.saturation`): the arm slows and stops at its limits, the task error grows instead
(unbounded, the solution near a singularity asks unbounded joint speeds and carries the joints past their limits).
Constraints that cannot be met raise :class:`~uvms.errors.SolverInputError` (never a velocity that leaves
them): rows C v = d without a solution, or (given dt) one beyond the model's speed or position limits.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..errors import ObjectiveError
from ..numerics.checks import check_scalar, prepared_gain
from ..numerics.inverses import SolverInputError, VariableDamping, pinv, smallest_singular_value, svd_inverse
from ..robot.configuration import Configuration
from ..robot.robot import Robot, check_robot
from ..tasks.objectives import JointLimits, JointVelocityLimits
from ..tasks.task import Task, as_task_list
from .base import Solver, check_free_floating, full_velocity, level_gains
from .result import SolvedRows, SolverResult
from .saturation import TOLERANCE, RateRows, speed_maximum
from .stack import stacked_terms

#: The damping of the task rows where [C; J] is near singular (amundsen2018 eq. 6): none while sigma_min >= 0.05.
SINGULAR_DAMPING = VariableDamping(0.05, 0.1)
#: Residual |C v - d| [units of d] beyond which constraint rows have no solution (relative to 1 + |d|).
CONSTRAINT_TOLERANCE = 1e-6


class ConstraintSolver(Solver):
    """Constraint rows met first and exactly, then the task rows (scenario method "kinematic_constraint").

    Args:
        robot: the model.
        levels: [constraints, tasks]: the constraint task(s) C v = d, then the task(s) J v = xdot.
        gain: one K for both, or [K of the constraint rows, K of the task rows] [1/s].
        free_floating: solve the arm only (generalized Jacobians), the vehicle by momentum conservation.
        dt: step [s]; when given, the task's part of v is kept inside the model's joint speed limits and the
            position-rate bounds of its joint limits, and constraints that need more are refused (module docstring).

    Raises:
        SolverInputError: not two levels of tasks, a bad gain or dt, free_floating on a fixed base; at
            :meth:`velocity`, constraints without a solution or (given dt) beyond the model's limits.
    """

    name = "kinematic_constraint"
    #: a scenario's [vehicle] task is the constraint, above the end-effector task
    vehicle_level = 0
    level_count = 2

    def __init__(self, robot: Robot, levels: Sequence[Task | Sequence[Task]], *, gain: float | Sequence = 1.0,
                 free_floating: bool = False, dt: float | None = None) -> None:
        check_robot(robot, "the kinematic constraint")
        if not isinstance(levels, (list, tuple)) or len(levels) != self.level_count:
            raise SolverInputError(f"the kinematic constraint needs two levels, [constraints, tasks] (each a task "
                                   f"or a list of tasks), got {levels!r}")
        self.robot, self.free_floating = robot, check_free_floating(robot, free_floating)
        self.constraints, self.tasks = as_task_list(levels[0]), as_task_list(levels[1])
        constraint_gain, task_gain = level_gains(gain, 2)
        self._constraint_command = prepared_gain(constraint_gain, sum(task.dim for task in self.constraints))
        self._command = prepared_gain(task_gain, sum(task.dim for task in self.tasks))
        self.size = robot.n_arm if self.free_floating else robot.nv
        self.dt = None if dt is None else check_scalar(dt, "dt", positive=True)
        bounded = self.dt is not None and robot.n_arm > 0
        self.maximum = speed_maximum(robot.nv, [JointVelocityLimits(robot)] if bounded else [])  # (nv,)
        try:
            limits = [JointLimits(robot)] if bounded else []
        except ObjectiveError:  # no arm joint with finite limits
            limits = []
        rows = RateRows.of(limits)
        from ..numerics._kernels.boxes import saturated_sum_into  # numba: loaded where a solver is built

        self._box = (saturated_sum_into, rows.q_index, rows.v_index, rows.low, rows.high, self.dt or 1.0, 1.0,
                     self.maximum, not self.free_floating, TOLERANCE)

    def velocity(self, configuration: Configuration) -> SolverResult:
        """The velocity at ``configuration``; ``sigma_min`` that of [C; J] (solved columns)."""
        state = self._checked(configuration)
        constraint_jacobian, constraint_error, feedforward = stacked_terms(state, self.constraints)
        constraint_values = self._constraint_command(constraint_error, feedforward)
        jacobian, error, feedforward = stacked_terms(state, self.tasks)
        command = self._command(error, feedforward)
        solved_constraints = state.generalized(constraint_jacobian) if self.free_floating else constraint_jacobian
        solved_tasks = state.generalized(jacobian) if self.free_floating else jacobian
        system = np.vstack([solved_constraints, solved_tasks])
        rhs = np.concatenate([constraint_values, command])
        sigma = smallest_singular_value(system)
        # constraints first (exact when consistent): their part of v, then the task's in their null space
        constraint_inverse = pinv(solved_constraints)
        constrained = constraint_inverse @ constraint_values
        residual = np.linalg.norm(solved_constraints @ constrained - constraint_values)
        if not residual <= CONSTRAINT_TOLERANCE * (1.0 + np.linalg.norm(constraint_values)):
            raise SolverInputError(f"the kinematic constraint has no solution here: its rows C v = d are "
                                   f"inconsistent (residual {residual:.3g}); impose independent velocities")
        used = 0.0
        if system.shape[0] == system.shape[1] and sigma >= SINGULAR_DAMPING.epsilon:
            solved = np.linalg.solve(system, rhs)  # the paper's exact solution
        else:
            projector = np.eye(self.size) - constraint_inverse @ solved_constraints
            inverse, _, used = svd_inverse(solved_tasks @ projector, SINGULAR_DAMPING)
            solved = constrained + projector @ (inverse @ (command - solved_tasks @ constrained))
        solved = self._bounded(state, constrained, solved)
        levels = (SolvedRows(0, constraint_jacobian, constraint_values, constraint_error),
                  SolvedRows(1, jacobian, command, error))
        return SolverResult(v=full_velocity(state, solved, self.free_floating), sigma_min=sigma, damping=used,
                            free_floating=self.free_floating, levels=levels)

    def _bounded(self, state: Configuration, constrained: np.ndarray, solved: np.ndarray) -> np.ndarray:
        """``solved`` (n,) with its task part (beyond ``constrained``, the constraints' part) scaled into the speed
        limits and position-rate bounds (unchanged inside them).

        Raises:
            SolverInputError: the constraints' part alone leaves them.
        """
        if self.dt is None:
            return solved
        saturated_sum_into, *constants = self._box
        contributions = np.array([constrained, solved - constrained])  # (2, n)
        velocities = (np.array([full_velocity(state, c, True) for c in contributions]) if self.free_floating
                      else contributions)
        total, scales = np.empty(self.size), np.empty(2)
        saturated_sum_into(contributions, velocities, state.q, *constants, total, scales)
        if scales[0] < 1.0:
            raise SolverInputError("the kinematic constraint cannot be met here: the velocities it imposes need "
                                   "arm joint speeds beyond the model's <limit velocity> or a joint past its "
                                   "position limits; impose smaller velocities or start farther from the limits")
        return solved if scales[1] == 1.0 else total
