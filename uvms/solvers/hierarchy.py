"""A priority hierarchy of equality tasks and inequality objectives: prepared once, evaluated per configuration.

Both hierarchical solvers read their levels from here: the set-based (iCAT) priority of
:mod:`uvms.solvers.set_based` and the QP cascade of :mod:`uvms.solvers.hqp`.

* :class:`HierarchyPlan` splits and checks the levels once (what each level holds, the speed limits, the
  joint-limit objectives, the task gains), where a solver is built;
* :meth:`HierarchyPlan.evaluate` stacks every level's rows at one configuration (a :class:`Hierarchy`),
  the kinematics computed once for all of them; with an :class:`ItemRows` it reads the items another hierarchy
  already evaluated at that configuration (the actuated chain's coordination re-solve);
* what both solvers report (the rows a result keeps, the speed ratio).
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from ..numerics._kernels import Kernel
from ..numerics.checks import prepared_gain
from ..numerics.inverses import SolverInputError
from ..robot.configuration import Configuration
from ..robot.kinematics import base_velocity_from_momentum, solve_base_block
from ..robot.robot import Robot, check_robot
from ..tasks.objectives import Inequality, InequalityRows, VelocityLimit
from ..tasks.task import Task
from .item_rows import ItemRows
from .result import SolvedRows
from .stack import stacked_terms

#: What a level may hold.
LevelItem = Task | Inequality | VelocityLimit
Levels = Sequence[LevelItem | Sequence[LevelItem]]


#: The compiled command of an equality level (:func:`uvms.numerics._kernels.command.command_into`, numba loaded at
#: the first evaluation).
_COMMAND_INTO = Kernel("command", "command_into")


# ----------------------------------------------------------------- the hierarchy at one configuration
@dataclass(slots=True)
class LevelRows:
    """One level evaluated at a configuration.

    Attributes:
        index: its position in the levels given (0 = highest).
        jacobian: (m, nv) world-aligned rows; solved: (m, n) the columns solved (generalized when free floating).
        reference: (m,) the rows' reference rates; activation: (m,) in [0, 1].
        objectives: the inequality objectives' rows at this configuration; inequalities: the objectives.
        task_jacobian, task_error, task_command: the equality tasks' stacked rows (0 rows if none).
        equality: the level holds equality tasks only (every activation is 1).
    """

    index: int
    jacobian: np.ndarray
    solved: np.ndarray
    reference: np.ndarray
    activation: np.ndarray
    objectives: list[InequalityRows] = field(default_factory=list)
    inequalities: Sequence[Inequality] = ()
    task_jacobian: np.ndarray | None = None
    task_error: np.ndarray | None = None
    task_command: np.ndarray | None = None
    equality: bool = False

    @property
    def has_tasks(self) -> bool:
        return self.task_error is not None and self.task_error.size > 0


class Hierarchy:
    """The levels of a problem at one configuration, stacked as the solvers read them, and how solved columns map
    to v.

    Every level's rows are written into three stacks (:meth:`HierarchyPlan.evaluate`), level after level at the
    plan's offsets; what one level holds (:attr:`levels`) is read from them as views when first asked for (the
    diagnostics of a result, the QP hierarchy).

    Attributes:
        state: the kinematic state.
        jacobians: (M, nv) every level's world-aligned rows; solved: (M, n) the columns solved (``jacobians`` itself
            unless free floating: the generalized rows); references: (M,); activations: (M,) in [0, 1].
        speed_limits: the speed limits found in the levels or given.
        joint_limits: the joint-limit objectives (their limits become position-rate bounds).
        free_floating: only the arm is solved.
        vehicle_map: free floating: T_b (n_vehicle, n_arm) with v_vehicle = T_b qdot_arm; else None.
    """

    def __init__(self, state: Configuration, plan: HierarchyPlan, stacks: tuple[np.ndarray, ...],
                 values: list, vehicle_map: np.ndarray | None) -> None:
        self.state, self._plan, self._values, self.vehicle_map = state, plan, values, vehicle_map
        self.jacobians, self.solved, self.references, self.activations = stacks
        self.speed_limits, self.joint_limits = plan.speed_limits, plan.joint_limits
        self.free_floating = plan.free_floating

    @cached_property
    def levels(self) -> list[LevelRows]:
        """The levels with rows (levels holding only speed limits are left out), views of the stacks."""
        plan = self._plan
        errors: list[np.ndarray | None] = [None] * len(plan.levels)
        objectives: list[list[InequalityRows]] = [[] for _ in plan.levels]
        for (number, _, _, command, _), value in zip(plan._blocks, self._values):
            if command is not None:
                errors[number] = value
            else:
                objectives[number].append(value)
        rows = []
        offsets = plan.offsets.tolist()
        for number, level in enumerate(plan.levels):
            span = slice(offsets[number], offsets[number + 1])
            task_error = errors[number]
            task_jacobian = task_command = None
            if task_error is not None:
                tasks = slice(offsets[number], offsets[number] + task_error.size)
                task_jacobian, task_command = self.jacobians[tasks], self.references[tasks]
            rows.append(LevelRows(level.index, self.jacobians[span], self.solved[span], self.references[span],
                                  self.activations[span], objectives[number], level.inequalities, task_jacobian,
                                  task_error, task_command, bool(plan.equality[number])))
        return rows

    def objective_rows(self) -> list[InequalityRows]:
        """The inequality objectives' rows, in priority order (those of :attr:`levels`, without forming them)."""
        values = self._values
        return [values[index] for index in self._plan._objective_blocks]

    @property
    def size(self) -> int:
        """Number of solved columns n (nv, or n_arm when free floating)."""
        robot = self.state.robot
        return robot.n_arm if self.free_floating else robot.nv

    def to_velocity(self, solved: np.ndarray) -> np.ndarray:
        """A contribution in v (nv,) from solved columns (n,) (linear: the vehicle by T_b when free floating)."""
        if not self.free_floating:
            return solved
        return np.concatenate([self.vehicle_map @ solved, solved])

    def velocity(self, solved: np.ndarray) -> np.ndarray:
        """The full velocity v (nv,) of a solution: the vehicle from momentum conservation when free floating."""
        if not self.free_floating:
            return solved
        a_base, a_arm = self.state.centroidal_split()
        return np.concatenate([base_velocity_from_momentum(a_base, a_arm, solved, None), solved])


def split_levels(levels: Levels) -> tuple[list[tuple[int, list[Task | Inequality]]], list[VelocityLimit]]:
    """(index, tasks and inequalities) per level, and the speed limits found anywhere.

    Raises:
        SolverInputError: no level, an empty level, or an item that is not a Task, an Inequality or a
            VelocityLimit.
    """
    if not isinstance(levels, (list, tuple)) or not levels:
        raise SolverInputError(f"levels must be a non-empty list of levels, each a Task, an Inequality, a "
                               f"VelocityLimit or a list of them, got {levels!r}")
    rows, limits = [], []
    for index, level in enumerate(levels):
        items = [level] if isinstance(level, (Task, Inequality, VelocityLimit)) else level
        if not isinstance(items, (list, tuple)):
            raise SolverInputError(f"level {index}: {level!r} is not a Task, an Inequality, a VelocityLimit or a "
                                   f"list of them")
        if not items:
            raise SolverInputError(f"level {index} is empty")
        bad = [item for item in items if not isinstance(item, (Task, Inequality, VelocityLimit))]
        if bad:
            raise SolverInputError(f"level {index}: {bad[0]!r} is not a Task, an Inequality or a VelocityLimit")
        limits.extend(item for item in items if isinstance(item, VelocityLimit))
        solved = [item for item in items if not isinstance(item, VelocityLimit)]
        if solved:
            rows.append((index, solved))
    return rows, limits


@dataclass(frozen=True)
class PlannedLevel:
    """One level's items, sorted once: equality tasks (stacked in order, then K applied), then inequalities."""

    index: int
    tasks: tuple[Task, ...]
    inequalities: tuple[Inequality, ...]
    command: object  # (error (k,), feedforward (k,)) -> xdot_d + K e (k,), the task gain prepared
    ones: np.ndarray  # (k,) the equality rows' activations


def _block_key(block: tuple) -> object:
    """What makes a block's rows another plan's at the same state: an objective's id; for a level's equality tasks
    their ids and a scalar gain K (a gain prepared per plan: None, never shared)."""
    _, item, key, command, _ = block
    if command is None:
        return id(item)
    return (key, command) if command.__class__ is float else None


class HierarchyPlan:
    """The levels of a hierarchy split and checked once; :meth:`evaluate` stacks their rows at a configuration.

    Args:
        robot: the model.
        levels: highest priority first; each level a Task, an Inequality, a VelocityLimit, or a list of them.
        gain: K of the equality tasks (scalar, (k,) or (k, k) for each level's stacked tasks) [1/s].
        free_floating: the solved columns are the arm's (generalized Jacobians, the vehicle by momentum).
        speed_limits: more speed limits (besides those in the levels).

    Raises:
        SolverInputError: malformed levels, a bad gain, or ``free_floating`` on a fixed base.
    """

    def __init__(self, robot: Robot, levels: Levels, gain: float | np.ndarray = 1.0, free_floating: bool = False,
                 speed_limits: Sequence[VelocityLimit] = ()) -> None:
        check_robot(robot, "the priority hierarchy")
        if free_floating and robot.base_type == "fixed":
            raise SolverInputError(f"{robot.name} has a fixed base: free_floating=True needs a floating or planar base")
        items, found = split_levels(levels)
        self.robot, self.free_floating = robot, free_floating
        if not isinstance(speed_limits, (list, tuple)) or not all(isinstance(limit, VelocityLimit)
                                                                  for limit in speed_limits):
            raise SolverInputError(f"speed_limits must be a list of VelocityLimit objectives (JointVelocityLimits, "
                                   f"VehicleVelocityLimits), got {speed_limits!r}")
        self.speed_limits = [*found, *speed_limits]
        self.levels = []
        for index, level in items:
            tasks = tuple(item for item in level if isinstance(item, Task))
            dim = sum(task.dim for task in tasks)
            command = prepared_gain(gain, dim) if tasks else None
            inequalities = tuple(item for item in level if isinstance(item, Inequality))
            self.levels.append(PlannedLevel(index, tasks, inequalities, command, np.ones(dim)))
        self.joint_limits = [item for level in self.levels for item in level.inequalities
                             if item.bounds_joint_positions]
        self.size = robot.n_arm if free_floating else robot.nv
        sizes = [sum(item.dim for item in (*level.tasks, *level.inequalities)) for level in self.levels]
        self.offsets = np.array([0, *itertools.accumulate(sizes)], dtype=np.int64)  # (L + 1,) each level's first row
        self.equality = np.array([bool(level.tasks) and not level.inequalities for level in self.levels])  # (L,)
        # the stacks' layout, read at every evaluation: rows M, each level's first row and span
        starts = self.offsets.tolist()
        self._count, self._starts, self._spans = starts[-1], starts[:-1], list(itertools.pairwise(starts))
        self._activations = np.zeros(self._count)  # (M,) the equality tasks' rows weigh 1
        self._nv = robot.nv  # the stacks' columns (the robot's property is a call)
        # the rows' blocks, level after level: (level, tasks, their key in an ItemRows, command, rows) for a level's
        # equality tasks (command: the scalar K, or prepared_gain's function), (level, objective, None, None, rows)
        # for each objective
        self._blocks: list[tuple[int, object, tuple | None, object, slice]] = []
        # a scalar K (checked by prepared_gain): the command written by one compiled call, prepared_gain's numbers
        scalar = float(gain) if np.ndim(gain) == 0 else None
        for number, (level, row) in enumerate(zip(self.levels, self._starts)):
            if level.tasks:
                self._activations[row:row + level.ones.size] = 1.0
                self._blocks.append((number, level.tasks, tuple(map(id, level.tasks)),
                                     level.command if scalar is None else scalar, slice(row, row + level.ones.size)))
                row += level.ones.size
            for item in level.inequalities:
                self._blocks.append((number, item, None, None, slice(row, row + item.dim)))
                row += item.dim
        self._objective_blocks = [index for index, block in enumerate(self._blocks) if block[3] is None]
        # what an evaluation reads: (runs copied, blocks taken, blocks evaluated), all evaluated without a source
        self._all = ([], [], [(index, *block[1:]) for index, block in enumerate(self._blocks)])
        self._gatherings: dict[HierarchyPlan, tuple[list, list, list]] = {}  # per source plan, made once
        self._stage: tuple | None = None  # :meth:`stage_stacks`' buffers and each block's views, made at its first call

    def _gathering(self, source: HierarchyPlan) -> tuple[list[tuple[slice, slice]], list[tuple[int, int]], list]:
        """How an evaluation reads the rows ``source``'s evaluation wrote (once per source plan): runs of rows (this
        plan's rows, the source's) copied at once, (block, source block) whose rows those are, and the blocks
        evaluated here: objectives the source does not hold, and equality tasks unless the source stacks the same
        tasks with the same scalar gain (their rows and command xdot_d + K e are then the source's numbers)."""
        found = self._gatherings.get(source)
        if found is None:
            where: dict[object, int] = {}  # an objective's id, or a task block's (ids, K) -> its first source block
            for index, block in enumerate(source._blocks):
                key = _block_key(block)
                if key is not None:
                    where.setdefault(key, index)
            runs, taken, blocks = [], [], []
            for index, block in enumerate(self._blocks):
                key = _block_key(block)
                origin = None if key is None else where.get(key)
                if origin is None:
                    blocks.append((index, *block[1:]))
                    continue
                taken.append((index, origin))
                target, rows = block[4], source._blocks[origin][4]
                if runs and runs[-1][0].stop == target.start and runs[-1][1].stop == rows.start:  # one run
                    runs[-1] = (slice(runs[-1][0].start, target.stop), slice(runs[-1][1].start, rows.stop))
                else:
                    runs.append((target, rows))
            found = self._gatherings[source] = (runs, taken, blocks)
        return found

    def evaluate(self, state: Configuration, shared: ItemRows | None = None) -> Hierarchy:
        """Every level's rows at ``state`` (its kinematics computed once) written into the stacks, and the map of
        solved columns to v; ``shared``: the items' rows another hierarchy evaluated at ``state`` (read, and filled
        with the others).

        The stacks are new at each evaluation (a result's diagnostics keep views of them); each level writes its
        rows at its offset (no per-level stack, no second concatenation)."""
        count = self._count
        stacks = np.empty((count, self._nv)), np.empty(count), self._activations.copy()  # the equality rows' 1
        values = self._fill(state, shared, stacks, None)
        jacobians, references, activations = stacks
        vehicle_map, solved = None, jacobians
        if self.free_floating:
            solved = (np.concatenate([state.generalized(jacobians[start:end]) for start, end in self._spans])
                      if self.levels else np.zeros((0, self.size)))
            a_base, a_arm = state.centroidal_split()
            vehicle_map = -solve_base_block(a_base, a_arm)  # (n_vehicle, n_arm)
        return Hierarchy(state, self, (jacobians, solved, references, activations), values, vehicle_map)

    def stage_stacks(self, state: Configuration,
                     shared: ItemRows | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The stacks (jacobians (M, nv), references (M,), activations (M,)) of :meth:`evaluate` at ``state``, the
        same numbers, in this plan's own buffers: valid until its next call, as are the objectives' rows ``shared``
        keeps from it (views of them). What a solve that returns v alone reads (an integrator's stage, a
        coordinated step's solves): no Hierarchy, no new stacks, each block's rows a view made once."""
        if self._stage is None:
            count = self._count
            stacks = np.empty((count, self._nv)), np.empty(count), np.empty(count)
            self._stage = stacks, [(stacks[0][rows], stacks[2][rows], stacks[1][rows]) for *_, rows in self._blocks]
        stacks, views = self._stage
        stacks[2][:] = self._activations  # the equality rows' 1; the objectives write theirs
        self._fill(state, shared, stacks, views)
        return stacks

    def _fill(self, state: Configuration, shared: ItemRows | None, stacks: tuple[np.ndarray, np.ndarray, np.ndarray],
              views: list | None) -> list:
        """Every block's rows at ``state`` written into ``stacks`` (jacobians, references, activations; the
        activations holding the equality rows' 1), through ``views`` (per block: its rows of the jacobians,
        activations and references) when given; the blocks' values (per block: the tasks' error, or the objective's
        rows)."""
        items = shared.at(state) if shared is not None else None
        jacobians, references, activations = stacks
        values = [None] * len(self._blocks)
        runs, taken, blocks = self._all
        source = None if items is None else items.source
        if source is not None and source[0] is not self:  # rows another hierarchy wrote: copied run by run
            runs, taken, blocks = self._gathering(source[0])
            source_jacobians, source_references, source_activations = source[1]
            for target, origin in runs:
                jacobians[target] = source_jacobians[origin]
                references[target] = source_references[origin]
                activations[target] = source_activations[origin]
            source_values = source[2]
            for index, origin in taken:
                values[index] = source_values[origin]
        first = items is not None and items.empty
        command_into = _COMMAND_INTO.function or _COMMAND_INTO.load()
        for index, item, key, command, rows in blocks:  # one loop over the plan's blocks, level after level
            jacobian, activation, reference = (views[index] if views is not None else
                                               (jacobians[rows], activations[rows], references[rows]))
            if command is not None:  # a level's equality tasks: their rows and command xdot_d + K e
                task_jacobian, task_error, feedforward = (stacked_terms(state, item) if items is None
                                                          else items.tasks(item, key))
                jacobian[:] = task_jacobian
                if command.__class__ is float:  # a scalar K
                    command_into(task_error, feedforward, command, reference)
                else:
                    reference[:] = command(task_error, feedforward)
                values[index] = task_error
            else:  # an objective's rows written in place (read where another hierarchy evaluated them)
                values[index] = (item.rows_into(state, jacobian, activation, reference) if items is None else
                                 items.objective_into(item, jacobian, activation, reference))
        if first:  # every objective evaluated here: the next hierarchy at this state copies them from these stacks
            items.source = (self, stacks, values)
        return values

    def state(self, q: np.ndarray | Configuration, check: bool = True) -> Configuration:
        """The kinematic state at q (a state given is used as it is)."""
        return q if isinstance(q, Configuration) else Configuration(self.robot, q, check=check)


# --------------------------------------------------------------------------------- reporting
def solved_rows(hierarchy: Hierarchy) -> tuple[SolvedRows, ...]:
    """Every level's rows as a result keeps them (its residuals and objectives computed when read)."""
    empty = np.zeros(0)
    return tuple(SolvedRows(index=level.index, jacobian=level.jacobian, reference=level.reference,
                            error=level.task_error if level.has_tasks else empty,
                            activation=None if level.equality else level.activation,
                            objectives=tuple(level.objectives)) for level in hierarchy.levels)


def speed_ratio(v: np.ndarray, maximum: np.ndarray) -> float:
    """max_i |v_i| / max_i over the finite speed limits (0 without any;
    :func:`~uvms.numerics._kernels.boxes.speed_ratio_of`)."""
    return float((_SPEED_RATIO.function or _SPEED_RATIO.load())(v, maximum))


#: numba loaded at the first call, not by ``import uvms``.
_SPEED_RATIO = Kernel("boxes", "speed_ratio_of")


def last_task_sigma(hierarchy: Hierarchy, sigmas: Sequence[float]) -> float:
    """sigma_min of the last level holding equality tasks (0 if none)."""
    values = [sigma for level, sigma in zip(hierarchy.levels, sigmas) if level.has_tasks]
    return float(values[-1]) if values else 0.0
