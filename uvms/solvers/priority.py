"""Task priority, any number of levels: classic (Nakamura/Siciliano-Slotine) and singularity-robust (Chiaverini).

classic:  v_i = v_{i-1} + (J_i P_{i-1})^+ (xdot_i - J_i v_{i-1}),   P_i = P_{i-1} - (J_i P_{i-1})^+ (J_i P_{i-1})
robust:   v = sum_i N_{i-1} J_i^+ xdot_i,   N_{i-1} = I - J_A^+ J_A with J_A the stack of levels 1..i-1

The robust form (used for UVMS by Antonelli and Chiaverini, the comparison of
santos2006) never inverts the product J_i P_{i-1}, so it has no algorithmic
singularity; the price is that lower levels are met only approximately even
when they could be met exactly. With ``free_floating`` every level's Jacobian is
its generalized form (only the arm is solved; the vehicle follows momentum).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..numerics.checks import check_choice, check_damping, check_matrix, check_vector, prepared_gain
from ..numerics.inverses import SolverInputError, dls, smallest_singular_value
from ..robot.configuration import Configuration
from ..robot.robot import Robot, check_robot
from ..tasks.task import Task, as_task_list
from .base import Solver, check_free_floating, full_velocity, level_gains
from .result import SolvedRows, SolverResult
from .stack import stacked_terms

#: The two forms of task priority.
METHODS = ("classic", "robust")


def prioritized(jacobians: Sequence[np.ndarray], commands: Sequence[np.ndarray], method: str = "robust",
                damping: float = 0.0) -> tuple[np.ndarray, list[float]]:
    """The prioritized solution (n,) of per-level Jacobians (k_i, n) and commands (k_i,), highest priority first,
    and the smallest singular value of each level's inverted Jacobian.

    Raises:
        SolverInputError: an unknown method, a bad damping, no level, or Jacobians and commands that do not
            match (the message says which level).
    """
    check_choice(method, "task-priority method", METHODS)
    if len(jacobians) != len(commands) or not jacobians:
        raise SolverInputError("task priority needs one command per Jacobian, and at least one level")
    damping = check_damping(damping)
    jacobians = [check_matrix(jacobian, f"level {level} Jacobian") for level, jacobian in enumerate(jacobians)]
    size = jacobians[0].shape[1]
    for level, jacobian in enumerate(jacobians):
        if jacobian.shape[1] != size:
            raise SolverInputError(f"level {level}: the Jacobian {jacobian.shape} "
                                   f"must have the {size} columns of level 0")
    commands = [check_vector(command, f"level {level} command", jacobian.shape[0])
                for level, (jacobian, command) in enumerate(zip(jacobians, commands))]
    v = np.zeros(size)
    projector = np.eye(size)
    sigmas = []
    for level, (jacobian, command) in enumerate(zip(jacobians, commands)):
        if method == "classic":
            projected = jacobian @ projector
            inverse = dls(projected, damping)
            v = v + inverse @ (command - jacobian @ v)
            projector = projector - inverse @ projected
            sigmas.append(smallest_singular_value(projected))
        else:
            inverse = dls(jacobian, damping)
            v = v + projector @ (inverse @ command)
            stacked = np.vstack(jacobians[: level + 1])
            projector = np.eye(size) - dls(stacked, 0.0) @ stacked
            sigmas.append(smallest_singular_value(jacobian))
    return v, sigmas


class PrioritySolver(Solver):
    """Task priority over levels of equality tasks (scenario method "task_priority"), commands xdot_d + K e.

    Args:
        robot: the model.
        levels: highest priority first; each level a task or a list of tasks (stacked).
        gain: one K for every level, or a list with one K per level [1/s].
        priority: "classic" or "robust" (singularity-robust).
        damping: DLS damping lambda >= 0 of every inversion.
        free_floating: solve the arm only (generalized Jacobians), the vehicle by momentum conservation.

    Raises:
        SolverInputError: no level, a bad gain, method or damping, free_floating on a fixed base.
    """

    name = "task_priority"
    #: a scenario's [vehicle] task is the level below the end-effector task
    vehicle_level = 1

    def __init__(self, robot: Robot, levels: Sequence[Task | Sequence[Task]], *, gain: float | Sequence = 1.0,
                 priority: str = "robust", damping: float = 0.0, free_floating: bool = False) -> None:
        check_robot(robot, "task priority")
        if not isinstance(levels, (list, tuple)) or not levels:
            raise SolverInputError(f"task priority needs a non-empty list of levels (each a task or a list of "
                                   f"tasks), got {levels!r}")
        self.robot, self.free_floating = robot, check_free_floating(robot, free_floating)
        self.levels = [as_task_list(level) for level in levels]
        self.priority = check_choice(priority, "task-priority method", METHODS)
        self.damping = check_damping(damping)
        self._commands = [prepared_gain(level_gain, sum(task.dim for task in level))
                          for level, level_gain in zip(self.levels, level_gains(gain, len(self.levels)))]

    def velocity(self, configuration: Configuration) -> SolverResult:
        """The prioritized velocity at ``configuration``; ``sigma_min`` the smallest over the levels (each
        level's in ``extras["level_sigma_min"]``)."""
        state = self._checked(configuration)
        rows, jacobians, commands = [], [], []
        for index, (level, command) in enumerate(zip(self.levels, self._commands)):
            jacobian, error, feedforward = stacked_terms(state, level)
            reference = command(error, feedforward)
            rows.append(SolvedRows(index, jacobian, reference, error))
            jacobians.append(state.generalized(jacobian) if self.free_floating else jacobian)
            commands.append(reference)
        solved, sigmas = prioritized(jacobians, commands, self.priority, self.damping)
        return SolverResult(v=full_velocity(state, solved, self.free_floating), sigma_min=float(min(sigmas)),
                            damping=self.damping, free_floating=self.free_floating, levels=tuple(rows),
                            extras={"method": self.priority, "level_sigma_min": tuple(sigmas)})
