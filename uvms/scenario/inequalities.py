"""A scenario's ``[[inequalities]]``: built on the model, recorded over the run, measured in ``metrics.json``.

Each table is one priority level, highest first, all above ``[task]``::

    [[inequalities]]
    type = "vehicle_attitude"     # joint_limits, joint_velocity, vehicle_attitude, plane_clearance, manipulability
    max_tilt = 0.0873             # [rad] (5 degrees)

A solver that enforces them (``Solver.enforces_inequalities``: ``"set_based"``, iCAT, and ``"hqp"``, the QP
cascade) makes them levels above the task. With another method they
are *monitored*: recorded and reported exactly the same way, not enforced (``metrics.json`` says
``"inequalities_enforced": false``), so the same scenario run with ``--set solver.method=clik`` shows what the
inequalities change.

The recorder evaluates every objective at every row from the configuration itself (not from the solver's
bounds), so the series are comparable between methods and between plants (the rows an actuated chain's solves
evaluated at the row's q with the nominal bounds are read instead: the same numbers, not computed twice);
"active" is the solver's own report when it gives one (a QP row binding for hqp, an activation > 0 for set_based)
in a kinematic run, else (a monitored method, or a dynamic [plant] run, whose row is the plant's)
an activation > 0. On a dynamic plant the speed ratio is that of the measured velocity v.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import ScenarioError, UVMSError
from ..robot.configuration import Configuration
from ..robot.robot import Robot
from ..solvers import SOLVERS
from ..solvers.hierarchy import speed_ratio
from ..solvers.item_rows import ItemRows
from ..solvers.saturation import speed_maximum
from ..tasks.objectives import Inequality, Objective, VelocityLimit, inequalities_from_table
from ..tasks.objectives.collision import NearestPairs
from .spec import InequalitySpec

#: An objective whose value is outside its valid set by more than this [its unit] is reported on the terminal:
#: the activation keeps it inside up to the step's discretization (a tilt limit can be passed by a fraction
#: of a degree between two solver calls), which is a result, not rounding.
VIOLATION_SLACK = 1e-6
#: A row's empty series (read, never written: the loop stacks the rows' into (N, 0) of these types).
NO_PAIRS, NO_VALUES, NO_ACTIVE = np.zeros(0, dtype=int), np.zeros(0), np.zeros(0, dtype=bool)


@dataclass
class ScenarioInequalities:
    """The inequality levels of a scenario, highest priority first.

    Attributes:
        levels: one list of objectives per ``[[inequalities]]`` table (a joint_velocity table with
            ``vehicle_max`` gives two speed limits).
        types: the table type of each level.
        enforced: whether the solver enforces them (set_based, hqp) or only monitors them.
    """

    levels: list[list[Objective]]
    types: list[str]
    enforced: bool

    @property
    def objectives(self) -> list[Inequality]:
        """The objectives with rows (every one but the speed limits), in priority order."""
        return [item for level in self.levels for item in level if isinstance(item, Inequality)]

    @property
    def speed_limits(self) -> list[VelocityLimit]:
        return [item for level in self.levels for item in level if isinstance(item, VelocityLimit)]

    def level_of(self, name: str) -> int:
        """The level (0 = highest) of the objective or speed limit called ``name``."""
        return next(index for index, level in enumerate(self.levels) if any(item.name == name for item in level))

    def type_of(self, name: str) -> str:
        return self.types[self.level_of(name)]


def build_inequalities(robot: Robot, tables: Sequence[InequalitySpec], enforced: bool) -> ScenarioInequalities:
    """The objectives of the scenario's tables on ``robot``, ``enforced`` (the controller holds them: a solver class's
    ``enforces_inequalities``, the MPC's constraints) or monitored.

    Raises:
        ScenarioError: an invalid value or name (frame, joint) of a table, or two objectives with one name.
    """
    levels, types = [], []
    for index, table in enumerate(tables):
        try:
            levels.append(inequalities_from_table(robot, table.table))
        except UVMSError as exc:
            raise ScenarioError(f"inequalities[{index}] ({table.type}): {exc}") from None
        types.append(table.type)
    names = [item.name for level in levels for item in level]
    repeated = sorted({name for name in names if names.count(name) > 1})
    if repeated:
        raise ScenarioError(f"inequalities: two objectives are called {repeated[0]!r}; give each its own "
                            f"name = '...' (results and metrics.json report them by name)")
    return ScenarioInequalities(levels, types, enforced=enforced)


class ObjectiveRecorder:
    """The inequality series of a row: every objective's value, activation and activity, and the speed ratio.

    Args:
        robot: the model; inequalities: the scenario's.
        evaluated: q (nq,) -> the objectives' rows a solve evaluated at q, or None (a controller's
            ``objective_rows``): read instead of evaluated again; None: every row evaluated here.

    Called with a row's (t, q, x, sample) of any run: the sample's ``rate[0]`` is the velocity (nv,) (the
    kinematic controller's, or a plant's measured v); a kinematic sample's ``info`` (a SolverResult) says which
    objectives are active.
    """

    def __init__(self, robot: Robot, inequalities: ScenarioInequalities,
                 evaluated: Callable[[np.ndarray], ItemRows | None] | None = None) -> None:
        self.robot, self.objectives, self.evaluated = robot, inequalities.objectives, evaluated
        self.maximum = speed_maximum(robot.nv, inequalities.speed_limits)  # (nv,) [m/s, rad/s], inf: none
        self._state: Configuration | None = None

    def __call__(self, t: float, q: np.ndarray, x: np.ndarray, sample: object) -> dict:
        # the solver's own report of which objectives are active (its activity, not its statuses' violations)
        return self.row(q, sample.rate[0], getattr(getattr(sample, "info", None), "activity", None),
                        None if self.evaluated is None else self.evaluated(q))

    def row(self, q: np.ndarray, v: np.ndarray, reported: dict | None = None, rows: ItemRows | None = None) -> dict:
        """The series of the row at q (nq,) and velocity v (nv,).

        Args:
            reported: which objectives are active by name, the solver's report (None or a name missing: an
                activation > 0).
            rows: the objectives' rows a solve evaluated at this q with their nominal bounds
                (:meth:`uvms.control.station.ActuatedKinematics.objective_rows`,
                :meth:`uvms.control.tracking.TrackingController.objective_rows`): their values, activations and
                a collision objective's pairs read, not evaluated again (the same numbers).

        Returns:
            "objective_value" and "objective_activation" (k,) as Python floats, "objective_active" (n_objectives,)
            as bools (the loop stacks the rows into float64 and bool arrays), "objective_pair" (pairs,) int,
            "speed_ratio"; without an objective with rows, empty arrays of those types.
        """
        if not self.objectives:  # only speed limits: empty series of the arrays' types
            return {"objective_value": NO_VALUES, "objective_activation": NO_VALUES, "objective_active": NO_ACTIVE,
                    "objective_pair": NO_PAIRS, "speed_ratio": speed_ratio(v, self.maximum)}
        state = None  # moved to q only when an objective is evaluated here
        values, activations, active, pairs = [], [], [], []  # Python floats and bools: made arrays by the loop
        for objective in self.objectives:
            if rows is not None:
                evaluated = rows.objective(objective)
                value, activation = evaluated.value, evaluated.activation
                if objective.collision:  # which pair each row is, for the metrics and the replay
                    pairs.append(evaluated.pairs)
            else:
                if state is None:
                    state = self._at(q)
                if objective.collision:  # which pair each row is, for the metrics and the replay
                    chosen, found = objective.nearest(state)
                    value = found.distance
                    pairs.append(chosen)
                else:
                    value = objective.value(state)
                activation = objective.activation(value)
            values += value.tolist()
            levels = activation.tolist()
            activations += levels
            is_active = None if reported is None else reported.get(objective.name)
            # an activation is in [0, 1]: one non-zero is (activation > 0).any(), without numpy's dispatch
            active.append(any(levels) if is_active is None else is_active)
        return {"objective_value": values, "objective_activation": activations, "objective_active": active,
                "objective_pair": np.concatenate(pairs).astype(int) if pairs else NO_PAIRS,
                "speed_ratio": speed_ratio(v, self.maximum)}

    def _at(self, q: np.ndarray) -> Configuration:
        """The recorder's kinematic state moved to q (one, its pin.Data made once)."""
        if self._state is None:
            self._state = Configuration(self.robot, q, check=False)
        else:
            self._state.update(q, check=False)
        return self._state


def vehicle_tilt(vehicle_pose: np.ndarray) -> np.ndarray:
    """Tilt (N,) [rad] of a floating vehicle from its poses (N, 6) [x, y, z, roll, pitch, yaw]: the angle between
    its z axis and the world's, cos tilt = cos roll cos pitch."""
    return np.arccos(np.clip(np.cos(vehicle_pose[:, 3]) * np.cos(vehicle_pose[:, 4]), -1.0, 1.0))


def inequality_metrics(inequalities: ScenarioInequalities, series: dict[str, np.ndarray]) -> dict:
    """The metrics of a run's inequalities from the recorder's series.

    Returns:
        ``inequalities_enforced``; ``min_clearance`` [m] and ``min_manipulability`` over their objectives
        (when any); ``max_joint_speed_ratio`` max_i |qdot_i| / max_i (when speed limits are given); and
        ``inequalities``: per objective its ``type``, ``level``, ``active_fraction`` (of the rows),
        ``max_activation``, ``max_violation`` (how far outside its valid set [its unit], 0 inside) and
        ``value_range`` [min, max] of its value over the run and its rows; a collision objective also its
        ``closest`` pair ({"pair", "distance" [m], "t" [s]}) and ``pairs_active``: per pair of links with an
        active row, the fraction of the rows it was active ("link1 / link2": fraction, largest first). With
        collision objectives ``min_self_distance`` and ``min_obstacle_distance`` [m] over them.
    """
    objectives = inequalities.objectives
    values, activations = series["objective_value"], series["objective_activation"]
    metrics: dict = {"inequalities_enforced": inequalities.enforced}
    per_objective, start = {}, 0
    minima: dict[str, list[float]] = {}  # an objective's min_metric -> the smallest value of each objective
    pair_start = 0
    for index, objective in enumerate(objectives):
        rows = slice(start, start + objective.dim)
        start += objective.dim
        value = values[:, rows]
        outside = np.maximum(objective.lower - value, value - objective.upper)
        per_objective[objective.name] = {
            "type": inequalities.type_of(objective.name),
            "level": inequalities.level_of(objective.name),
            "active_fraction": float(np.mean(series["objective_active"][:, index])),
            "max_activation": float(activations[:, rows].max(initial=0.0)),
            "max_violation": float(max(outside.max(initial=0.0), 0.0)),
            "value_range": [float(value.min()), float(value.max())],
        }
        if objective.collision:
            pairs = series["objective_pair"][:, pair_start: pair_start + objective.dim]
            pair_start += objective.dim
            per_objective[objective.name].update(pair_metrics(objective, series["t"], value, activations[:, rows],
                                                              pairs))
        if objective.min_metric:
            minima.setdefault(objective.min_metric, []).append(float(value.min()))
    for limit in inequalities.speed_limits:
        per_objective[limit.name] = {"type": inequalities.type_of(limit.name),
                                     "level": inequalities.level_of(limit.name)}
    metrics.update({key: min(values) for key, values in minima.items()})
    if inequalities.speed_limits:
        metrics["max_joint_speed_ratio"] = float(series["speed_ratio"].max())
    metrics["inequalities"] = per_objective
    return metrics


def pair_metrics(objective: NearestPairs, t: np.ndarray, value: np.ndarray, activation: np.ndarray,
                 pairs: np.ndarray) -> dict:
    """The closest pair of a collision objective over a run and the fraction of rows each pair was active.

    Args:
        objective: the objective (its ``links`` name the pairs); t: (N,) [s].
        value, activation, pairs: (N, dim) its rows' distances [m], activations and pair indices.
    """
    row, column = np.unravel_index(np.argmin(value), value.shape)
    names = [f"{first} / {second}" for first, second in objective.links]
    counts = np.zeros(len(names))
    for index in range(len(names)):  # a pair holds at most one row per step
        counts[index] = np.count_nonzero(np.any((pairs == index) & (activation > 0), axis=1))
    active = {names[k]: float(counts[k] / len(t)) for k in np.argsort(-counts, kind="stable") if counts[k] > 0}
    return {"closest": {"pair": names[pairs[row, column]], "distance": float(value[row, column]), "t": float(t[row])},
            "pairs_active": active}


def inequality_warnings(metrics: dict) -> list[str]:
    """One sentence per objective that left its valid set (from :func:`inequality_metrics`)."""
    warnings = []
    enforced = metrics.get("inequalities_enforced", True)
    for name, entry in metrics.get("inequalities", {}).items():
        if entry.get("max_violation", 0.0) > VIOLATION_SLACK:
            enforcing = " or ".join(repr(name) for name, cls in SOLVERS.items() if cls.enforces_inequalities)
            how = "" if enforced else f" (monitored only: solver.method = {enforcing} enforces it)"
            warnings.append(f"{name} left its valid set by up to {entry['max_violation']:.3g}{how}")
    ratio = metrics.get("max_joint_speed_ratio", 0.0)
    if ratio > 1.0 + 1e-9:
        how = "" if enforced else " (monitored only)"
        warnings.append(f"a speed reached {ratio:.3g} times its limit (max_joint_speed_ratio){how}")
    return warnings
