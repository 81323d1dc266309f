"""The Task interface, and a task with some of its columns' velocity given (:class:`GivenColumns`)."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence

import numpy as np

from ..errors import SolverInputError
from ..robot.configuration import Configuration


class Task(ABC):
    """Something to achieve, expressed as k scalar rows.

    Subclasses give ``error`` (k,) = desired - current, ``jacobian`` (k, nv) with
    d(current)/dt = J v, and ``feedforward`` (k,) = d(desired)/dt.
    """

    #: number of rows
    dim: int

    @abstractmethod
    def error(self, state: Configuration) -> np.ndarray:
        """Task error e = desired - current (k,)."""

    @abstractmethod
    def jacobian(self, state: Configuration) -> np.ndarray:
        """Task Jacobian (k, nv): d(current)/dt = J v."""

    def feedforward(self, state: Configuration) -> np.ndarray:  # noqa: ARG002 - state used by subclasses
        """Desired task velocity (k,); zero unless a target velocity was set."""
        return np.zeros(self.dim)

    def terms(self, state: Configuration) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(jacobian (k, nv), error (k,), feedforward (k,)) at ``state``, what a solver stacks; a task whose three
        share work (a frame task's rotations) computes them at once."""
        return self.jacobian(state), self.error(state), self.feedforward(state)


def as_task_list(tasks: Task | Sequence[Task]) -> list[Task]:
    """One task or several -> a non-empty list of tasks."""
    try:
        task_list = [tasks] if isinstance(tasks, Task) else list(tasks)
    except TypeError:  # not iterable (None, a number): refused below with the others
        task_list = []
    if not task_list or not all(isinstance(task, Task) for task in task_list):
        raise SolverInputError(f"expected a Task or a sequence of Tasks, got {tasks!r}")
    return task_list


class GivenColumns(Task):
    """A task whose first columns' velocity is given: its terms with the feedforward less what they give,
    xdot_d - J[:, :n] nu (the task the arm is left with when the vehicle's velocity nu is fixed).

    Args:
        task: the task; count: the given columns n (the vehicle's).

    Attributes:
        velocity: nu (n,) the given columns' velocity, set before each solve.
    """

    def __init__(self, task: Task, count: int) -> None:
        self.task, self.dim, self.velocity = task, task.dim, np.zeros(count)

    def error(self, state: Configuration) -> np.ndarray:
        return self.task.error(state)

    def jacobian(self, state: Configuration) -> np.ndarray:
        return self.task.jacobian(state)

    def terms(self, state: Configuration) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        jacobian, error, feedforward = self.task.terms(state)
        return jacobian, error, feedforward - jacobian[:, :self.velocity.size] @ self.velocity
