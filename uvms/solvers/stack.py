"""Stacking tasks into one system J v = xdot_d + K e."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..numerics.checks import apply_gain, gain_matrix
from ..robot.configuration import Configuration
from ..tasks.task import Task, as_task_list

__all__ = ["as_task_list", "gain_matrix", "stack", "stacked_terms"]


def stack(state: Configuration, tasks: Sequence[Task],
          gain: float | np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Stacked Jacobian (k, nv), error (k,) and command xdot_d + K e (k,) of several tasks."""
    jacobian, error, feedforward = stacked_terms(state, tasks)
    return jacobian, error, feedforward + apply_gain(gain, error)


def stacked_terms(state: Configuration, tasks: Sequence[Task]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Jacobian (k, nv), error (k,) and feedforward (k,) of the tasks, stacked in order (one task: its own)."""
    if len(tasks) == 1:
        return tasks[0].terms(state)
    jacobians, errors, feedforwards = zip(*(task.terms(state) for task in tasks))
    return np.vstack(jacobians), np.concatenate(errors), np.concatenate(feedforwards)
