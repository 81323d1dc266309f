"""Inequality objectives: a valid set instead of a target, with a smooth activation at its border.

* :class:`JointLimits` — arm joint positions, ``margin`` inside the model's limits;
* :class:`VehicleAttitude` — the vehicle's tilt (roll and pitch) below ``max_tilt``;
* :class:`PlaneClearance` — a frame or the vehicle at least ``min`` from a plane (seabed, wall);
* :class:`Manipulability` — the arm's manipulability at a frame above ``min``;
* :class:`FrameBox` — a frame inside a box;
* :class:`SelfCollision` — the robot's ``<collision>`` shapes at least ``min`` apart (the nearest pairs);
* :class:`Obstacle` — the robot's shapes at least ``min`` from a box, sphere, cylinder, plane or mesh in the world;
* :class:`JointVelocityLimits`, :class:`VehicleVelocityLimits` — speed limits, bounds of the solvers.

:func:`inequalities_from_table` builds them from plain parameters (a scenario's ``[[inequalities]]`` table),
checking the type and every key against the valid ones.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Mapping

from ...errors import ObjectiveError, ObjectiveNameNotFound
from ...robot.robot import Robot
from .base import ACTIVATION_SHAPES, Inequality, InequalityRows, bell
from .collision import Obstacle, SelfCollision
from .frames import FrameBox, PlaneClearance, VehicleAttitude
from .joints import JointLimits
from .manipulability import Manipulability
from .velocity import JointVelocityLimits, VehicleVelocityLimits, VelocityLimit, velocity_limits


def registered(*kinds: type[Inequality]) -> dict[str, Callable[..., object]]:
    """Registry entries of objective classes: each one's ``type_name`` -> the class."""
    return {kind.type_name: kind for kind in kinds}


#: A scenario's inequality ``type`` -> the constructor its other keys are passed to (as keywords): every
#: :class:`Inequality` class by its ``type_name``, and the speed limits' factory.
INEQUALITY_TYPES: dict[str, Callable[..., object]] = {
    **registered(JointLimits),
    "joint_velocity": velocity_limits,
    **registered(VehicleAttitude, PlaneClearance, Manipulability, FrameBox, SelfCollision, Obstacle),
}

Objective = Inequality | VelocityLimit
#: Constructor parameters that take Python objects, not plain data: not keys of a table.
NOT_TABLE_KEYS = ("limit",)


def file_keys(type_name: str) -> tuple[str, ...]:
    """The table keys of an inequality type that name a file (its class's ``file_keys``): a scenario resolves them
    inside its own folder (:func:`uvms.scenario.resources.scenario_file`)."""
    return tuple(getattr(INEQUALITY_TYPES.get(type_name), "file_keys", ()))


def collision_types() -> list[str]:
    """The inequality types of collision objectives (their class's ``collision``), in registry order."""
    return [name for name, kind in INEQUALITY_TYPES.items() if getattr(kind, "collision", False)]


def table_keys(type_name: str) -> tuple[list[str], list[str]]:
    """(every key, the required ones) of an inequality type, from its constructor's signature."""
    parameters = [p for p in list(inspect.signature(INEQUALITY_TYPES[type_name]).parameters.values())[1:]
                  if p.name not in NOT_TABLE_KEYS]  # after robot
    keys = [p.name for p in parameters]
    return keys, [p.name for p in parameters if p.default is inspect.Parameter.empty]


def check_table(table: Mapping[str, object], where: str = "inequalities") -> tuple[str, dict]:
    """The type and the other keys of an ``[[inequalities]]`` table, checked against the valid ones (no model needed).

    Raises:
        ObjectiveNameNotFound: an unknown type or key (the message lists the close ones).
        ObjectiveError: a required key missing.
    """
    params = dict(table)
    type_name = params.pop("type", None)
    if not isinstance(type_name, str) or type_name not in INEQUALITY_TYPES:
        raise ObjectiveNameNotFound("inequality type", str(type_name), list(INEQUALITY_TYPES), where=where)
    keys, required = table_keys(type_name)
    for key in params:
        if key not in keys:
            raise ObjectiveNameNotFound(f"key of a {type_name} inequality", key, keys, where=where)
    missing = [key for key in required if key not in params]
    if missing:
        raise ObjectiveError(f"{where}: a {type_name} inequality needs {', '.join(missing)} "
                             f"(keys: {', '.join(keys)})")
    return type_name, params


def inequalities_from_table(robot: Robot, table: Mapping[str, object]) -> list[Objective]:
    """The objective(s) of one ``[[inequalities]]`` table: ``type`` plus its constructor's keywords.

    Args:
        robot: the model.
        table: {"type": one of :data:`INEQUALITY_TYPES`, key: value...}, e.g.
            {"type": "plane_clearance", "frame": "vehicle", "point": [0, 0, -10], "normal": [0, 0, 1], "min": 0.5}.

    Returns:
        A list: one objective, or two for a ``joint_velocity`` table with ``vehicle_max``.

    Raises:
        ObjectiveNameNotFound: an unknown type or key (the message lists the close ones).
        ObjectiveError: a required key missing, or an invalid value.
    """
    type_name, params = check_table(table)
    built = INEQUALITY_TYPES[type_name](robot, **params)
    return list(built) if isinstance(built, list) else [built]  # type: ignore[list-item]


__all__ = [
    "ACTIVATION_SHAPES", "FrameBox", "INEQUALITY_TYPES", "Inequality", "InequalityRows", "JointLimits",
    "JointVelocityLimits", "Manipulability", "Objective", "Obstacle", "PlaneClearance", "SelfCollision",
    "VehicleAttitude", "VehicleVelocityLimits", "VelocityLimit", "bell", "check_table", "collision_types",
    "file_keys", "inequalities_from_table", "registered", "table_keys", "velocity_limits",
]
