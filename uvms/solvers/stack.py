"""Stacking tasks into one system J v = xdot_d + K e."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..state import KinematicState
from ..tasks.task import Task
from .checks import apply_gain, as_task_list, gain_matrix

__all__ = ["as_task_list", "gain_matrix", "stack"]


def stack(state: KinematicState, tasks: Sequence[Task], gain: float | np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Stacked Jacobian (k, nv), error (k,) and command xdot_d + K e (k,) of several tasks."""
    jacobian = np.vstack([task.jacobian(state) for task in tasks])
    error = np.concatenate([task.error(state) for task in tasks])
    feedforward = np.concatenate([task.feedforward(state) for task in tasks])
    command = feedforward + apply_gain(gain, error)
    return jacobian, error, command
