"""Joint and vehicle speed limits ``|v_i| <= max_i``: bounds of the solvers, not tasks.

The set-based solver meets them by scaling the lowest-priority contributions first
(:mod:`uvms.solvers.saturation`); the QP hierarchy by hard bounds. Place them anywhere in the levels
(their level does not matter) or pass them on their own.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from ...errors import LimitError, ObjectiveError, ObjectiveNameNotFound
from ...robot.limits import Limit
from ...robot.robot import Robot


class VelocityLimit:
    """A box ``|v_i| <= maximum_i`` on the entries of v, read from a velocity :class:`Limit`.

    Attributes:
        name: how results name it.
        limit: the velocity :class:`Limit` of the entries it limits (the arm's, or the vehicle's).
        maximum: (nv,) [m/s, rad/s] > 0: ``limit.upper`` on its entries, +inf on the others (vehicle entries
            in the vehicle's local axes, the order of v): what the solvers read.
    """

    name: str
    limit: Limit
    maximum: np.ndarray

    def _set_maximum(self, robot: Robot, entries: np.ndarray, values: np.ndarray) -> None:
        if values.shape != entries.shape or np.any(np.isnan(values)) or np.any(values <= 0):
            raise ObjectiveError(f"{self.name}: speed limits must be numbers > 0 (inf: none), got {values}")
        self.maximum = np.full(robot.nv, np.inf)
        self.maximum[entries] = values

    def __repr__(self) -> str:
        limited = np.isfinite(self.maximum)
        return f"{type(self).__name__}({self.name!r}, {int(limited.sum())} entries limited)"


def _numbers(value: object, what: str) -> np.ndarray:
    """``value`` as a float array, else ObjectiveError naming ``what``."""
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ObjectiveError(f"{what} must be numbers [m/s or rad/s], got {value!r}") from None


def _by_name(values: Mapping[str, float], names: Sequence[str], kind: str, where: str) -> np.ndarray:
    """A per-entry array from {name: value}; names checked with the close ones; unnamed entries +inf."""
    array = np.full(len(names), np.inf)
    for key, value in values.items():
        if key not in names:
            raise ObjectiveNameNotFound(kind, str(key), names, where=where)
        array[list(names).index(key)] = _numbers(value, f"{where}: {key}")
    return array


class JointVelocityLimits(VelocityLimit):
    """``|qdot_i| <= max_i`` on the arm joints [rad/s or m/s]: the box of a velocity :class:`Limit`.

    Args:
        robot: the model.
        max: None (the model's ``<limit velocity>``; 0 there means none), one number for every arm joint,
            n_arm numbers, or {joint name: value} (:meth:`Limit.joint_velocities`).
        name: the name results report.
        limit: a symmetric velocity :class:`Limit` of the n_arm arm coordinates instead of ``max``.

    Attributes:
        limit: the velocity :class:`Limit` read (n_arm,); ``maximum`` holds its upper bounds on the arm entries.

    Raises:
        LimitError: a bad ``max`` or ``limit``, or both given.
    """

    def __init__(self, robot: Robot, max: float | Sequence[float] | Mapping[str, float] | None = None,  # noqa: A002
                 name: str = "joint_velocity", limit: Limit | None = None) -> None:
        self.name = name
        if limit is not None and max is not None:
            raise LimitError(f"{name}: give the speed limits as max or as a velocity limit, not both")
        self.limit = Limit.joint_velocities(robot, max) if limit is None else Limit.arm(robot, limit, "velocity", name)
        if not np.array_equal(-self.limit.lower, self.limit.upper):
            raise LimitError(f"{name}: speed limits are |v_i| <= max_i, symmetric; got lower {self.limit.lower} "
                             f"and upper {self.limit.upper}")
        self._set_maximum(robot, np.arange(robot.n_vehicle, robot.nv), self.limit.upper)


class VehicleVelocityLimits(VelocityLimit):
    """``|nu_i| <= max_i`` on the vehicle twist (body axes, the vehicle entries of v) [m/s, rad/s].

    Args:
        robot: a model with a floating or planar base.
        max: [linear m/s, angular rad/s] (two numbers), one per vehicle entry (``robot.base.velocity_names``:
            vx, vy, vz, wx, wy, wz or vx, vy, wz), or {entry name: value}.
        name: the name results report.

    Attributes:
        limit: the velocity :class:`Limit` of the vehicle's entries (n_vehicle,), named by velocity name.
    """

    def __init__(self, robot: Robot, max: Sequence[float] | Mapping[str, float],  # noqa: A002
                 name: str = "vehicle_velocity") -> None:
        self.name = name
        if robot.base_type == "fixed":
            raise ObjectiveError(f"{name}: {robot.name} has a fixed base, it has no vehicle velocity to limit")
        names = robot.base.velocity_names
        if isinstance(max, Mapping):
            values = _by_name(max, names, "vehicle velocity", name)
        else:
            values = _numbers(max, f"{name}: max").reshape(-1)
            if values.size == 2:
                values = np.array([values[0] if entry.startswith("v") else values[1] for entry in names])
            elif values.size != len(names):
                raise ObjectiveError(f"{name}: max must be [linear m/s, angular rad/s] or {len(names)} numbers "
                                     f"({', '.join(names)}), got {max!r}")
        self._set_maximum(robot, np.arange(robot.n_vehicle), values)
        self.limit = Limit(-values, values, tuple(names), kind="velocity")


def velocity_limits(robot: Robot, max: float | Sequence[float] | Mapping[str, float] | None = None,  # noqa: A002
                    vehicle_max: Sequence[float] | Mapping[str, float] | None = None) -> list[VelocityLimit]:
    """The ``joint_velocity`` table of a scenario: arm joint limits and, if given, vehicle limits."""
    limits: list[VelocityLimit] = [JointVelocityLimits(robot, max)]
    if vehicle_max is not None:
        limits.append(VehicleVelocityLimits(robot, vehicle_max))
    return limits
