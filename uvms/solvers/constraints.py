"""Kinematic constraints (santos2006): impose some velocity magnitudes, solve the others exactly.

The constraint tasks C v = d (e.g. vehicle u = v = 0 and a yaw rate that turns
the vehicle toward the current) and the end-effector task J v = xdot are
solved together as one system [C; J] v = [d; xdot]: exactly when it is square
and regular — the Davies-method solution N_s Y_s = -N_p Y_p of the paper
(see :mod:`uvms.solvers.screws`) — and in the least-squares sense otherwise,
with the residual reported. With ``free_floating`` both are their generalized
forms (only the arm is solved; the vehicle follows momentum conservation).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..numerics.checks import prepared_gain
from ..numerics.inverses import RCOND, SolverInputError, pinv, smallest_singular_value
from ..robot.configuration import Configuration
from ..robot.robot import Robot, check_robot
from ..tasks.task import Task, as_task_list
from .base import Solver, check_free_floating, full_velocity, level_gains
from .result import SolvedRows, SolverResult
from .stack import stacked_terms


class ConstraintSolver(Solver):
    """Constraint rows met first and exactly, then the task rows (scenario method "kinematic_constraint").

    Args:
        robot: the model.
        levels: [constraints, tasks]: the constraint task(s) C v = d, then the task(s) J v = xdot.
        gain: one K for both, or [K of the constraint rows, K of the task rows] [1/s].
        free_floating: solve the arm only (generalized Jacobians), the vehicle by momentum conservation.

    Raises:
        SolverInputError: not two levels of tasks, a bad gain, free_floating on a fixed base.
    """

    name = "kinematic_constraint"
    #: a scenario's [vehicle] task is the constraint, above the end-effector task
    vehicle_level = 0
    level_count = 2

    def __init__(self, robot: Robot, levels: Sequence[Task | Sequence[Task]], *, gain: float | Sequence = 1.0,
                 free_floating: bool = False) -> None:
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
        if system.shape[0] == system.shape[1] and smallest_singular_value(system) > RCOND * np.abs(system).max():
            solved = np.linalg.solve(system, rhs)
        else:
            # constraints first (exact when consistent), then the task in their null space
            constraint_inverse = pinv(solved_constraints)
            solved = constraint_inverse @ constraint_values
            projector = np.eye(self.size) - constraint_inverse @ solved_constraints
            solved = solved + pinv(solved_tasks @ projector) @ (command - solved_tasks @ solved)
        levels = (SolvedRows(0, constraint_jacobian, constraint_values, constraint_error),
                  SolvedRows(1, jacobian, command, error))
        return SolverResult(v=full_velocity(state, solved, self.free_floating),
                            sigma_min=smallest_singular_value(system), damping=0.0, free_floating=self.free_floating,
                            levels=levels)
