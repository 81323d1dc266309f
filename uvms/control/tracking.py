"""The kinematic tracking controller: a task follows a trajectory, a solver gives the velocity the robot takes."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..dynamics.plant.command import Command, State
from ..robot.configuration import Configuration
from ..robot.robot import Robot
from ..solvers.base import SolverFactory
from ..solvers.item_rows import ItemRows
from .reference import TaskReference


class TrackingController:
    """The :class:`~uvms.control.base.Controller` of a kinematic run: ``Command(velocity=v, info=SolverResult)``.

    One Configuration is kept and moved to each q asked about (``update``), not one built per call.

    Args:
        robot: the model; reference: the end-effector task and the trajectory it follows (its last samples kept:
            RK4 stages share times).
        solver: the solver, built once here on ``levels``.
        levels: the levels, highest first; one of them holds ``task``.

    Raises:
        SolverInputError: what the solver refuses of the levels or its options.
    """

    def __init__(self, robot: Robot, reference: TaskReference, solver: SolverFactory, levels: Sequence) -> None:
        self.robot, self.task_reference, self.task = robot, reference, reference.task
        self.solver = solver(levels)  # its inputs checked here, not at every evaluation
        self._configuration: Configuration | None = None  # built at the first call
        # the objectives' rows of the last solve, for the run's recorder (a solver that shares rows fills them)
        self._rows = ItemRows() if getattr(self.solver, "shares_rows", False) else None

    def reset(self, state: State, t: float = 0.0) -> None:
        """Forget the target the task points at (the configuration kept is moved at every call)."""
        self.task_reference.forget()

    def command(self, state: State, t: float) -> Command:
        """``Command(velocity=v (nv,), info=the SolverResult: sigma_min, damping, limits_active, ...)`` at (t, q);
        the diagnostics are computed when read."""
        rows = self._rows
        if self.task_reference.follow(t) and rows is not None:
            rows.clear()  # the task's rows are those of its last target
        q = state.q  # from pin.integrate in the one loop (checked once at its start): not validated at every call
        if self._configuration is None:
            self._configuration = Configuration(self.robot, q, check=False)
        else:
            self._configuration.update(q, check=False)
        result = self.solver.velocity(self._configuration) if rows is None else \
            self.solver.velocity(self._configuration, shared=rows)
        return Command(velocity=result.v, info=result)

    def stage_velocity(self, q: np.ndarray, t: float) -> np.ndarray:
        """v (nv,) of :meth:`command`'s velocity at (t, q), the same numbers, without the command and its diagnostics
        (an integrator's stage: :meth:`uvms.sim.kinematic.KinematicSystem.stage_rate`). A solver sharing its rows with
        the recorder is asked through :meth:`command`, which keeps them."""
        if self._rows is not None or self._configuration is None:
            return self.command(State(q), t).velocity
        self.task_reference.follow(t)
        self._configuration.update(q, check=False)
        return self.solver.stage_velocity(self._configuration)

    def objective_rows(self, q: np.ndarray) -> ItemRows | None:
        """The objectives' rows the last solve evaluated at ``q`` (nq,) (a recorder reads them instead of evaluating
        them again; an objective that solve did not evaluate is evaluated there at its first read), or None: a
        solver that does not share rows, or the last solve was at another q."""
        return None if self._rows is None else self._rows.evaluated_at(q)
