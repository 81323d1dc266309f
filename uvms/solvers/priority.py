"""Task priority, any number of levels: classic (Nakamura/Siciliano-Slotine) and singularity-robust (Chiaverini).

classic:  v_i = v_{i-1} + (J_i P_{i-1})^+ (xdot_i - J_i v_{i-1}),   P_i = P_{i-1} - (J_i P_{i-1})^+ (J_i P_{i-1})
robust:   v = sum_i N_{i-1} J_i^+ xdot_i,   N_{i-1} = I - J_A^+ J_A with J_A the stack of levels 1..i-1

The robust form (used for UVMS by Antonelli and Chiaverini, the comparison of
santos2006) never inverts the product J_i P_{i-1}, so it has no algorithmic
singularity; the price is that lower levels are met only approximately even
when they could be met exactly.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..robot.robot import Robot
from ..robot.configuration import Configuration
from ..tasks.task import Task
from ..numerics.checks import check_choice, check_damping, check_matrix, check_vector
from ..numerics.inverses import SolverInputError, dls, smallest_singular_value
from .results import PriorityResult
from .stack import as_task_list, stack

METHODS = ("classic", "robust")


def task_priority(
    jacobians: Sequence[np.ndarray], commands: Sequence[np.ndarray], method: str = "robust", damping: float = 0.0
) -> PriorityResult:
    """Prioritized velocity from per-level Jacobians (k_i, n) and commands (k_i,), highest priority first."""
    check_choice(method, "task-priority method", METHODS)
    if len(jacobians) != len(commands) or not jacobians:
        raise SolverInputError("task priority needs one command per Jacobian, and at least one level")
    damping = check_damping(damping)
    jacobians = [check_matrix(jacobian, f"level {level} Jacobian") for level, jacobian in enumerate(jacobians)]
    size = jacobians[0].shape[1]
    for level, jacobian in enumerate(jacobians):
        if jacobian.shape[1] != size:
            raise SolverInputError(f"level {level}: the Jacobian {jacobian.shape} must have the {size} columns of level 0")
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
    residuals = tuple(float(np.linalg.norm(j @ v - c)) for j, c in zip(jacobians, commands))
    return PriorityResult(v=v, residuals=residuals, sigma_min=tuple(sigmas), damping=damping, method=method)


def priority_velocity(
    robot: Robot,
    q: np.ndarray | Configuration,
    levels: Sequence[Task | Sequence[Task]],
    *,
    gain: float | Sequence[float] = 1.0,
    method: str = "robust",
    damping: float = 0.0,
) -> PriorityResult:
    """Task priority over task levels (each a task or a list of tasks), commands xdot_d + K e.

    ``gain`` is one K for every level or one per level.
    """
    state = q if isinstance(q, Configuration) else Configuration(robot, q)
    gains = list(gain) if isinstance(gain, (list, tuple)) and len(levels) > 1 else [gain] * len(levels)
    if len(gains) != len(levels):
        raise SolverInputError(f"{len(levels)} levels need one gain each, got {len(gains)}")
    jacobians, commands = [], []
    for level, level_gain in zip(levels, gains):
        jacobian, _, command = stack(state, as_task_list(level), level_gain)
        jacobians.append(jacobian)
        commands.append(command)
    return task_priority(jacobians, commands, method=method, damping=damping)
