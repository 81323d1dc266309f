"""The one solver interface: built once from the robot, the levels and the options; a velocity per configuration.

Every velocity method (CLIK, task priority, kinematic constraints, set-based, the QP hierarchy) is a
:class:`Solver`: its constructor checks its inputs and prepares what does not change between calls (the
gains, the weights' factor, the levels' split, the bounds' rows); :meth:`Solver.velocity` solves at a
:class:`~uvms.robot.configuration.Configuration` and returns a :class:`~uvms.solvers.result.SolverResult`;
:meth:`Solver.step` also moves the configuration along the solution. Free floating (the generalized
Jacobian: only the arm is solved, the vehicle follows momentum conservation) is an option of every solver.

What the scenario builder reads from a class, never from its name:

* :attr:`Solver.name`: the scenario's ``solver.method``;
* :meth:`Solver.options`: the keywords its constructor takes (a solver key a method does not take is refused);
* :attr:`Solver.enforces_inequalities`: the ``[[inequalities]]`` become levels above the task (else monitored);
* :attr:`Solver.vehicle_level`: where a ``[vehicle]`` task goes among the levels (None: not used);
* :attr:`Solver.level_count`: the number of levels it needs (None: any);
* :attr:`Solver.holds_priorities`: its levels are held by priority (a lower one in the null space of the higher
  ones); False: stacked and traded off (CLIK). A controller that gives some velocities (the actuated chain's
  vehicle) puts them on a level at the top of a solver that holds priorities, else fixes their columns.
* :attr:`Solver.shares_rows`: :meth:`Solver.velocity` takes ``shared=`` an
  :class:`~uvms.solvers.item_rows.ItemRows`, the rows of its tasks and objectives another solver over some of the
  same items already evaluated at the configuration (the actuated chain's two solves at one q evaluate them once).

A controller receives its solver in one form, a :class:`SolverFactory` (the class and its options, built per
level set); it asks the class's attributes above, never the class itself.
"""

from __future__ import annotations

import inspect
import math
from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from ..errors import SolverInputError
from ..numerics.checks import check_scalar
from ..robot.configuration import Configuration
from ..robot.kinematics import base_velocity_from_momentum
from ..robot.robot import Robot
from .result import SolverResult


class Solver(ABC):
    """A velocity solver of fixed levels, its inputs checked and its pieces prepared at construction.

    Subclasses take ``(robot, levels, *, options...)`` and implement :meth:`velocity`; what changes between
    calls is the configuration and the tasks' targets (set on the task objects).

    Attributes:
        name: the scenario's ``solver.method`` of this class.
        enforces_inequalities: inequality objectives are levels it enforces (else a scenario monitors them).
        vehicle_level: the index a scenario's ``[vehicle]`` task takes in the levels (None: not used).
        level_count: the number of levels it needs (None: any number).
        holds_priorities: its levels are held by priority (False: stacked and traded off, as CLIK does).
        shares_rows: :meth:`velocity` also takes ``shared`` (an ItemRows: the items' rows at the configuration, read
            where another solver evaluated them and filled with the others).
        robot: the model; free_floating: only the arm is solved, the vehicle follows momentum conservation.
    """

    name: ClassVar[str]
    enforces_inequalities: ClassVar[bool] = False
    vehicle_level: ClassVar[int | None] = None
    level_count: ClassVar[int | None] = None
    holds_priorities: ClassVar[bool] = True
    shares_rows: ClassVar[bool] = False

    robot: Robot
    free_floating: bool

    @classmethod
    def options(cls) -> tuple[str, ...]:
        """The keywords its constructor takes (after the robot and the levels), in order."""
        parameters = inspect.signature(cls.__init__).parameters.values()
        return tuple(p.name for p in parameters if p.kind is inspect.Parameter.KEYWORD_ONLY)

    @abstractmethod
    def velocity(self, configuration: Configuration) -> SolverResult:
        """The velocity v (nv,) at ``configuration`` (the tasks pointed at their targets) and its diagnostics.

        Raises:
            SolverInputError: not a Configuration of this solver's robot.
        """

    def stage_velocity(self, configuration: Configuration, shared: Any = None) -> np.ndarray:
        """v (nv,) of :meth:`velocity` alone, the same numbers, without its diagnostics: what an integrator's stage
        reads (a solver with a cheaper way to v alone overrides it); ``shared``: as :meth:`velocity` takes it, for a
        solver that :attr:`shares_rows`."""
        return (self.velocity(configuration) if shared is None else self.velocity(configuration, shared=shared)).v

    def step(self, configuration: Configuration, dt: float) -> SolverResult:
        """Solve at ``configuration``, then move it along v for dt [s] (explicit Euler on the manifold, in place).

        Returns:
            The result at the configuration before the step.

        Raises:
            SolverInputError: dt not > 0, or not a Configuration of this solver's robot.
        """
        dt = checked_step(dt)
        result = self.velocity(configuration)
        configuration.integrate(result.v, dt)
        return result

    def _checked(self, configuration: Configuration) -> Configuration:
        """``configuration`` if it is one of this solver's robot."""
        if not isinstance(configuration, Configuration) or configuration.robot is not self.robot:
            raise SolverInputError(f"{type(self).__name__}.velocity needs a uvms.Configuration of the robot it was "
                                   f"built for ({self.robot.name}), got {type(configuration).__name__}: build one with "
                                   f"Configuration(robot, q)")
        return configuration


@dataclass(frozen=True)
class SolverFactory:
    """A solver class and its options, built on a level set: ``factory(levels, **keywords) -> Solver``.

    The one form in which a controller receives its solver: it builds one per level set it needs (the actuated
    chain's reference and coordination, a sequence's phases with and without a distance) and adds the keywords it
    owns (e.g. the GJM controller's ``free_floating`` and gain), which win over ``options``. What the solver can
    do is read from ``cls``'s attributes (:attr:`Solver.holds_priorities`, :attr:`Solver.enforces_inequalities`,
    :attr:`Solver.vehicle_level`, :attr:`Solver.level_count`, :meth:`Solver.options`).

    Attributes:
        cls: the Solver class (e.g. of :data:`uvms.solvers.SOLVERS`); robot: the model it is built for;
        options: its constructor's keywords.
    """

    cls: type[Solver]
    robot: Robot
    options: Mapping[str, Any] = field(default_factory=dict)

    def __call__(self, levels: Sequence, **keywords: Any) -> Solver:
        """The solver built on ``levels`` (highest first) with ``options`` and ``keywords``.

        Raises:
            SolverInputError: what the solver refuses (a bad level, option or value).
        """
        return self.cls(self.robot, levels, **{**self.options, **keywords})


def checked_step(dt: float) -> float:
    """A step dt > 0 [s] as a float (a positive float passes without a call).

    Raises:
        SolverInputError: dt not a finite number > 0.
    """
    if dt.__class__ is float and 0.0 < dt < math.inf:
        return dt
    return check_scalar(dt, "dt", positive=True)


def check_free_floating(robot: Robot, free_floating: bool) -> bool:
    """``free_floating`` if the robot has a vehicle to float.

    Raises:
        SolverInputError: free_floating on a fixed base.
    """
    if free_floating and robot.base_type == "fixed":
        raise SolverInputError(f"{robot.name} has a fixed base: free_floating=True needs a floating or planar base")
    return bool(free_floating)


def level_gains(gain: float | np.ndarray | Sequence, count: int) -> list:
    """One gain K per level: ``gain`` a list or tuple of ``count`` gains, else the same K for every level.

    Raises:
        SolverInputError: a list of gains whose length is not the number of levels.
    """
    if isinstance(gain, (list, tuple)) and count > 1:
        if len(gain) != count:
            raise SolverInputError(f"{count} levels need one gain each, got {len(gain)}")
        return list(gain)
    return [gain] * count


def full_velocity(configuration: Configuration, solved: np.ndarray, free_floating: bool) -> np.ndarray:
    """v (nv,) of a solution over the solved columns (n,): itself, or with free floating the arm's velocity
    and the vehicle's from momentum conservation (the one formula of :mod:`uvms.robot.kinematics`)."""
    if not free_floating:
        return solved
    a_base, a_arm = configuration.centroidal_split()
    return np.concatenate([base_velocity_from_momentum(a_base, a_arm, solved, None), solved])
