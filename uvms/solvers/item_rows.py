"""The rows of tasks and objectives evaluated at one configuration, kept by item for a second hierarchy at the same
configuration (the actuated chain's coordination re-solve) and for a run's recorder."""

from __future__ import annotations

import numpy as np

from ..robot.configuration import Configuration
from ..tasks.objectives import Inequality, InequalityRows
from ..tasks.task import Task
from .stack import stacked_terms


class ItemRows:
    """The rows of tasks and objectives evaluated at one configuration, by item, for a second hierarchy over some of
    the same items at the same configuration: the actuated chain re-solves the arm at the q of its reference through
    levels that share the reference's objectives and task
    (:meth:`~uvms.solvers.hierarchy.HierarchyPlan.evaluate` fills it at the first solve and reads it at the second),
    so each is evaluated once per step; a run's recorder reads the objectives' rows of the step's q from it
    (:meth:`evaluated_at`).

    Its owner says what it holds: the rows stay valid while the tasks' targets and the objectives' bounds are those
    of the first evaluation, and the owner calls :meth:`clear` before one of them changes. An evaluation at another
    configuration (another state, or q changed by value) empties it itself.
    """

    def __init__(self) -> None:
        self.state: Configuration | None = None
        self.q: list[float] = []  # the q the rows were evaluated at, as floats (compared by value at each read)
        self._objectives: dict[int, tuple[Inequality, InequalityRows]] = {}  # id -> (objective kept alive, rows)
        self._tasks: dict[tuple[int, ...], tuple[tuple[Task, ...], tuple]] = {}  # ids -> (tasks, stacked terms)
        #: (plan, (jacobians, references, activations), values) of the hierarchy that evaluated every one of its
        #: objectives into these rows first (:meth:`HierarchyPlan.evaluate
        #: <uvms.solvers.hierarchy.HierarchyPlan.evaluate>`): a second one copies its objectives' rows from those
        #: stacks, a run of rows at a time; None: no such evaluation yet
        self.source: tuple | None = None

    def clear(self) -> None:
        """Forget every row (a target or a bound is about to change)."""
        self.state = self.source = None
        self._objectives.clear()
        self._tasks.clear()

    @property
    def empty(self) -> bool:
        """No objective's rows kept yet."""
        return not self._objectives

    def evaluated_at(self, q: np.ndarray) -> ItemRows | None:
        """These rows when they were evaluated at q (nq,) (compared by value), else None: what a recorder of the
        row at q reads instead of evaluating the objectives again."""
        return self if self.state is not None and q.tolist() == self.q else None

    def at(self, state: Configuration) -> ItemRows:
        """These rows for ``state``: emptied first when they were evaluated at another state or q."""
        q = state.q.tolist()  # one read; list equality is numpy's elementwise == over every entry (NaN unequal)
        if state is not self.state or q != self.q:
            self.clear()
            self.state, self.q = state, q
        return self

    def objective(self, item: Inequality) -> InequalityRows:
        """The objective's rows at the state (evaluated at the first call)."""
        kept = self._objectives.get(id(item))
        if kept is None:
            kept = self._objectives[id(item)] = (item, item.rows(self.state))
        return kept[1]

    def objective_into(self, item: Inequality, jacobian: np.ndarray, activation: np.ndarray,
                       reference: np.ndarray) -> InequalityRows:
        """The objective's rows at the state written into a solver's stacked rows (:meth:`Inequality.rows_into
        <uvms.tasks.objectives.base.Inequality.rows_into>` at the first call, copied from the rows kept after)."""
        kept = self._objectives.get(id(item))
        if kept is None:
            rows = item.rows_into(self.state, jacobian, activation, reference)
            self._objectives[id(item)] = (item, rows)
            return rows
        rows = kept[1]
        jacobian[:] = rows.jacobian
        activation[:] = rows.activation
        reference[:] = rows.reference
        return rows

    def tasks(self, tasks: tuple[Task, ...],
              key: tuple[int, ...] | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The tasks' stacked (Jacobian, error, feedforward) at the state (:func:`~uvms.solvers.stack.stacked_terms`,
        evaluated at the first call; never written by a solver); ``key``: the tasks' ids when the caller has them."""
        key = tuple(map(id, tasks)) if key is None else key
        kept = self._tasks.get(key)
        if kept is None:
            kept = self._tasks[key] = (tasks, stacked_terms(self.state, tasks))
        return kept[1]
