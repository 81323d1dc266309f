"""Stacking tasks into one system J v = xdot_d + K e."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..state import KinematicState
from ..tasks.task import Task
from .inverses import SolverInputError


def as_task_list(tasks: Task | Sequence[Task]) -> list[Task]:
    """One task or several -> a non-empty list."""
    task_list = [tasks] if isinstance(tasks, Task) else list(tasks)
    if not task_list or not all(isinstance(task, Task) for task in task_list):
        raise SolverInputError(f"expected a Task or a sequence of Tasks, got {tasks!r}")
    return task_list


def gain_matrix(gain: float | np.ndarray, size: int) -> np.ndarray:
    """The CLIK gain K as a (size, size) positive-definite matrix (scalar, diagonal or full)."""
    gain_array = np.asarray(gain, dtype=float)
    if gain_array.ndim == 0:
        gain_array = np.full(size, float(gain_array))
    if gain_array.ndim == 1:
        if gain_array.shape != (size,) or not np.all(np.isfinite(gain_array)) or np.any(gain_array < 0):
            raise SolverInputError(f"gain must be a finite scalar >= 0, ({size},) or ({size}, {size}), got {gain!r}")
        return np.diag(gain_array)
    if gain_array.shape != (size, size) or not np.all(np.isfinite(gain_array)):
        raise SolverInputError(f"gain must be a finite scalar, ({size},) or ({size}, {size}), got shape {gain_array.shape}")
    symmetric = 0.5 * (gain_array + gain_array.T)
    if np.any(np.linalg.eigvalsh(symmetric) < 0):
        raise SolverInputError("gain K must be positive (semi-)definite")
    return gain_array


def stack(state: KinematicState, tasks: Sequence[Task], gain: float | np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Stacked Jacobian (k, nv), error (k,) and command xdot_d + K e (k,) of several tasks."""
    jacobian = np.vstack([task.jacobian(state) for task in tasks])
    error = np.concatenate([task.error(state) for task in tasks])
    feedforward = np.concatenate([task.feedforward(state) for task in tasks])
    command = feedforward + gain_matrix(gain, error.size) @ error
    return jacobian, error, command
