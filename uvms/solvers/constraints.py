"""Kinematic constraints (santos2006): impose some velocity magnitudes, solve the others exactly.

The constraint tasks C v = d (e.g. vehicle u = v = 0 and a yaw rate that turns
the vehicle toward the current) and the end-effector task J v = xdot are
solved together as one system [C; J] v = [d; xdot]: exactly when it is square
and regular — the Davies-method solution N_s Y_s = -N_p Y_p of the paper
(see :mod:`uvms.solvers.screws`) — and in the least-squares sense otherwise,
with the residual reported.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..robot.robot import Robot
from ..robot.configuration import Configuration
from ..tasks.task import Task
from ..numerics.inverses import RCOND, pinv, smallest_singular_value
from .results import VelocityResult
from .stack import as_task_list, stack


def constrained_velocity(
    robot: Robot,
    q: np.ndarray | Configuration,
    tasks: Task | Sequence[Task],
    constraints: Task | Sequence[Task],
    *,
    gain: float | np.ndarray = 1.0,
    constraint_gain: float | np.ndarray | None = None,
) -> VelocityResult:
    """Velocity meeting the constraint rows first and exactly, then the task rows.

    ``gain`` is the K of the task rows; ``constraint_gain`` that of the constraint rows (default: ``gain``).

    Returns:
        VelocityResult; ``residual`` is the task residual, ``sigma_min`` that of [C; J].
    """
    state = q if isinstance(q, Configuration) else Configuration(robot, q)
    constraint_jacobian, _, constraint_values = stack(
        state, as_task_list(constraints), gain if constraint_gain is None else constraint_gain)
    jacobian, error, command = stack(state, as_task_list(tasks), gain)
    system = np.vstack([constraint_jacobian, jacobian])
    rhs = np.concatenate([constraint_values, command])
    if system.shape[0] == system.shape[1] and smallest_singular_value(system) > RCOND * np.abs(system).max():
        v = np.linalg.solve(system, rhs)
    else:
        # constraints first (exact when consistent), then the task in their null space
        constraint_inverse = pinv(constraint_jacobian)
        v = constraint_inverse @ constraint_values
        projector = np.eye(robot.nv) - constraint_inverse @ constraint_jacobian
        v = v + pinv(jacobian @ projector) @ (command - jacobian @ v)
    return VelocityResult(v=v, command=command, error=error, residual=float(np.linalg.norm(jacobian @ v - command)),
                          sigma_min=smallest_singular_value(system), damping=0.0)
