"""Joint limits as one concept: which coordinates are limited, where, and how to clamp, project and bound.

A :class:`Limit` is a box ``lower <= x <= upper`` on coordinates of the robot
(the arm's joint values or velocities, in the order of v), with margins
(:meth:`Limit.shrink`). The model's are built once per robot (:meth:`Limit.joint_positions`,
:meth:`Limit.joint_velocities`: the same read-only object at every call) and every user of
limits reads them here, through :meth:`Limit.arm` (the one given, checked, or the model's): the mid-range
potential S(q) of hoang2011 (its middle and range), the joint clamping of CLIK
(which coordinates a step would push out and to which bound), the set-based
objectives (``JointLimits``: the box of its rows and its valid set inside the
margins; ``JointVelocityLimits`` and ``VehicleVelocityLimits``: the speed box), the projection of pose IK (q
clipped into the box), the bounds of the initial-configuration optimizer
(scipy's ``(lo, hi)`` pairs) and a run's ``max_joint_limit_violation`` (:meth:`Limit.excess`).

Coordinates without a finite bound (continuous joints, the vehicle) are
unbounded (+-inf); a continuous joint keeps its (cos, sin) pair in q, which a
projection leaves alone.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import LimitError, NameNotFound
from .robot import Robot

#: Slack [rad or m] within which a value on the wrong side of a bound still counts as inside.
TOLERANCE = 1e-12
KINDS = ("position", "velocity")


@dataclass(frozen=True, eq=False)
class Limit:
    """Box limits lower <= x <= upper on n coordinates.

    Build one with :meth:`joint_positions` or :meth:`joint_velocities`; the
    constructor takes arrays for a box of your own.

    Attributes:
        lower: lower bounds (n,) [rad or m; rad/s or m/s]; -inf where unbounded.
        upper: upper bounds (n,); +inf where unbounded.
        names: the joint owning each coordinate (n,).
        q_index: index in q of each coordinate (n,), -1 where q does not hold the value
            itself (continuous joints store (cos, sin); the vehicle; velocities).
        kind: "position" or "velocity".
    """

    lower: np.ndarray
    upper: np.ndarray
    names: tuple[str, ...] = ()
    q_index: np.ndarray | None = None
    kind: str = "position"

    def __post_init__(self) -> None:
        lower = np.array(self.lower, dtype=float).reshape(-1)
        upper = np.array(self.upper, dtype=float).reshape(-1)
        size = lower.size
        names = tuple(self.names) if self.names else tuple(f"x{i}" for i in range(size))
        q_index = (np.full(size, -1, dtype=int) if self.q_index is None
                   else np.array(self.q_index, dtype=int).reshape(-1))
        if upper.size != size or len(names) != size or q_index.size != size:
            raise LimitError(f"a limit needs as many lower/upper bounds, names and q indices, got "
                                   f"{size}, {upper.size}, {len(names)}, {q_index.size}")
        if np.any(np.isnan(lower)) or np.any(np.isnan(upper)) or np.any(lower > upper):
            raise LimitError(f"limits must satisfy lower <= upper (+-inf for unbounded), got {lower} and {upper}")
        if self.kind not in KINDS:
            raise LimitError(f"unknown limit kind {self.kind!r}; valid: {', '.join(KINDS)}")
        for array in (lower, upper, q_index):
            array.flags.writeable = False  # a Limit is shared (the model's, by every user): never changed in place
        for name, value in (("lower", lower), ("upper", upper), ("names", names), ("q_index", q_index)):
            object.__setattr__(self, name, value)

    # ---------------------------------------------------------- builders
    @classmethod
    def joint_positions(cls, robot: Robot, margin: float = 0.0) -> Limit:
        """The arm's joint position limits (n_arm,) from the model, optionally ``margin`` inside them.

        Args:
            robot: the model (its ``lowerPositionLimit`` / ``upperPositionLimit``).
            margin: distance kept from each finite bound [rad or m], >= 0.

        Raises:
            LimitError: a negative margin, or one that leaves no room inside a joint's range.
        """
        return cls._of_model(robot, "position").shrink(margin)

    @classmethod
    def _of_model(cls, robot: Robot, kind: str) -> Limit:
        """The model's ``kind`` limits of the arm, read from the model now (nothing kept: a model changed in place
        gives its new limits)."""
        return cls._position_limits(robot) if kind == "position" else cls._velocity_limits(robot, None)

    @classmethod
    def _position_limits(cls, robot: Robot) -> Limit:
        """The arm's position limits read from the model (``Robot.arm_limits``)."""
        lower, upper = robot.arm_limits
        names, q_index = [], []
        for joint in robot.arm_joints:
            names.extend([joint.name] * joint.nv)
            scalar = joint.nq == joint.nv
            q_index.extend(range(joint.idx_q, joint.idx_q + joint.nq) if scalar else [-1] * joint.nv)
        return cls(lower, upper, tuple(names), np.array(q_index, dtype=int))

    @classmethod
    def joint_velocities(cls, robot: Robot,
                         max: float | Sequence[float] | Mapping[str, float] | None = None) -> Limit:  # noqa: A002
        """The arm's joint velocity limits ``|v_i| <= v_max,i`` (n_arm,) [rad/s or m/s], the model's or given.

        Args:
            robot: the model (its ``velocityLimit``: a limit of 0, the URDF placeholder for "not given",
                counts as unbounded).
            max: None (the model's), one number for every arm coordinate, n_arm numbers, or
                {joint name: value} (the joints not named are unbounded); each > 0 (inf: none).

        Raises:
            LimitError: a value <= 0, NaN or not a number, or the wrong count.
            NameNotFound: a name in ``max`` that is not an arm joint (the message lists the close ones).
        """
        return cls._of_model(robot, "velocity") if max is None else cls._velocity_limits(robot, max)

    @classmethod
    def _velocity_limits(cls, robot: Robot, max: float | Sequence[float] | Mapping[str, float] | None) -> Limit:  # noqa: A002
        """The arm's velocity limits: the model's when ``max`` is None, else ``max`` checked."""
        names = tuple(joint.name for joint in robot.arm_joints for _ in range(joint.nv))
        if max is None:
            v_max = np.array(robot.model.velocityLimit[robot.n_vehicle:], dtype=float)
            v_max = np.where(v_max > 0, v_max, np.inf)
        elif isinstance(max, Mapping):
            v_max = np.full(len(names), np.inf)
            for joint, value in max.items():
                if joint not in names:
                    raise NameNotFound("arm joint", str(joint), sorted(set(names)), where="joint speed limits")
                v_max[[i for i, owner in enumerate(names) if owner == joint]] = _number(value, f"the speed of {joint}")
        else:
            v_max = _numbers(max, "joint speed limits")
            v_max = np.full(robot.n_arm, float(v_max)) if v_max.ndim == 0 else v_max
            if v_max.shape != (robot.n_arm,):
                raise LimitError(f"joint speed limits must be one number or {robot.n_arm} (one per arm coordinate: "
                                 f"{', '.join(names)}), got {max!r}")
        if np.any(np.isnan(v_max)) or np.any(v_max <= 0):
            raise LimitError(f"joint speed limits must be numbers > 0 [rad/s or m/s] (inf: none), got {max!r}")
        return cls(-v_max, v_max, names, kind="velocity")

    @classmethod
    def arm(cls, robot: Robot, limit: Limit | None = None, kind: str = "position", user: str = "this use") -> Limit:
        """``limit`` checked to be ``kind`` limits of the robot's n_arm arm coordinates, or the model's when None.

        What every user of joint limits calls with the ``limit`` it was given (the potential, the set-based
        objectives; CLIK's clamping and the initial configuration may too).

        Args:
            robot: the model.
            limit: the box to use, or None for :meth:`joint_positions` / :meth:`joint_velocities` of the model.
            kind: "position" or "velocity".
            user: who asks, for the message (e.g. "the mid-range potential").

        Raises:
            LimitError: a box of another size or kind.
        """
        if kind not in KINDS:
            raise LimitError(f"unknown limit kind {kind!r}; valid: {', '.join(KINDS)}")
        if limit is None:
            return cls.joint_positions(robot) if kind == "position" else cls.joint_velocities(robot)
        if limit.size != robot.n_arm or limit.kind != kind:
            raise LimitError(f"{user} needs {kind} limits of the {robot.n_arm} arm coordinates, got {limit.size} "
                             f"{limit.kind} limits")
        return limit

    def take(self, index: np.ndarray | Sequence[int]) -> Limit:
        """The box of the coordinates ``index`` (m,) only, in that order."""
        index = np.asarray(index, dtype=int)
        return Limit(self.lower[index], self.upper[index], tuple(self.names[i] for i in index), self.q_index[index],
                     self.kind)

    def margins(self, margin: float | Mapping[str, float], where: str = "") -> np.ndarray:
        """The margin (n,) >= 0 [rad or m] of each coordinate from one number or {joint name: margin} (others: 0).

        Raises:
            LimitError: a margin negative, NaN, infinite or not a number.
            NameNotFound: a joint of the mapping that owns none of the coordinates.
        """
        prefix = f"{where}: " if where else ""
        if isinstance(margin, Mapping):
            for joint in margin:
                if joint not in self.names:
                    raise NameNotFound("limited joint", str(joint), sorted(set(self.names)), where=where)
            values = np.array([_number(margin.get(joint, 0.0), f"{prefix}margin of {joint}") for joint in self.names])
        else:
            values = np.full(self.size, _number(margin, f"{prefix}margin"))
        if not np.all(np.isfinite(values)) or np.any(values < 0):
            raise LimitError(f"{prefix}a limit margin must be finite and >= 0 [rad or m], one number or "
                             f"{{joint: margin}}, got {margin!r}")
        return values

    def shrink(self, margin: float | Mapping[str, float], where: str = "") -> Limit:
        """The box with every finite bound moved ``margin`` inward [rad or m].

        Args:
            margin: one distance for every coordinate, or {joint name: distance} (joints not named: 0), >= 0.
            where: who asks, for the messages.

        Raises:
            LimitError: a bad margin (:meth:`margins`), or one that leaves no room inside a coordinate's range.
            NameNotFound: a joint of the mapping that owns none of the coordinates.
        """
        values = self.margins(margin, where)
        if not np.any(values):
            return self
        too_narrow = self.bounded & (self.upper - self.lower <= 2 * values)
        if np.any(too_narrow):
            joints = [f"{self.names[i]} [{self.lower[i]:g}, {self.upper[i]:g}]" for i in np.flatnonzero(too_narrow)]
            raise LimitError(f"{f'{where}: ' if where else ''}margin {margin} leaves no room inside the limits of "
                             f"{', '.join(joints)}; give a smaller one, one per joint {{joint: margin}}, or leave "
                             f"those joints out")
        return Limit(np.where(np.isfinite(self.lower), self.lower + values, self.lower),
                     np.where(np.isfinite(self.upper), self.upper - values, self.upper), self.names, self.q_index,
                     self.kind)

    def after_unbounded(self, count: int, name: str = "vehicle") -> Limit:
        """This box preceded by ``count`` unbounded coordinates (the vehicle's columns of v)."""
        unbounded = np.full(count, np.inf)
        return Limit(np.concatenate([-unbounded, self.lower]), np.concatenate([unbounded, self.upper]),
                     (name,) * count + self.names, np.concatenate([np.full(count, -1), self.q_index]), self.kind)

    # -------------------------------------------------------------- facts
    @property
    def size(self) -> int:
        """Number of coordinates n."""
        return self.lower.size

    @property
    def bounded(self) -> np.ndarray:
        """(n,) bool: both bounds finite and a range of positive width."""
        return np.isfinite(self.lower) & np.isfinite(self.upper) & (self.upper > self.lower)

    @property
    def middle(self) -> np.ndarray:
        """(lower + upper) / 2 (n,) where both bounds are finite, 0 elsewhere."""
        finite = np.isfinite(self.lower) & np.isfinite(self.upper)
        middle = np.zeros(self.size)
        middle[finite] = 0.5 * (self.lower[finite] + self.upper[finite])
        return middle

    @property
    def span(self) -> np.ndarray:
        """upper - lower (n,) where :attr:`bounded`, 1 elsewhere (a safe divisor)."""
        bounded = self.bounded
        span = np.ones(self.size)
        span[bounded] = self.upper[bounded] - self.lower[bounded]
        return span

    # ---------------------------------------------------------- operations
    def violated(self, values: np.ndarray, tolerance: float = TOLERANCE) -> np.ndarray:
        """(n,) bool: coordinates more than ``tolerance`` outside the box."""
        return (values < self.lower - tolerance) | (values > self.upper + tolerance)

    def excess(self, values: np.ndarray) -> np.ndarray:
        """How far each value is outside the box (..., n) [rad or m; rad/s or m/s], 0 inside; values may be rows."""
        return np.maximum(np.maximum(self.lower - values, values - self.upper), 0.0)

    def contains(self, values: np.ndarray, tolerance: float = TOLERANCE) -> bool:
        """Whether every coordinate of ``values`` (n,) is inside the box, up to ``tolerance``."""
        return bool(np.all(values >= self.lower - tolerance) and np.all(values <= self.upper + tolerance))

    def crossed_bound(self, values: np.ndarray) -> np.ndarray:
        """(n,) the bound each coordinate is pushed against: lower where values < lower, else upper."""
        return np.where(values < self.lower, self.lower, self.upper)

    def clamp(self, values: np.ndarray) -> np.ndarray:
        """``values`` (n,) clipped into the box."""
        return np.clip(values, self.lower, self.upper)

    def project(self, q: np.ndarray) -> np.ndarray:
        """A copy of the configuration q (nq,) with every coordinate that q holds itself clipped into the box."""
        q = np.array(q, dtype=float)
        held = self.q_index >= 0
        index = self.q_index[held]
        q[index] = np.clip(q[index], self.lower[held], self.upper[held])
        return q

    def bounds(self) -> list[tuple[float | None, float | None]]:
        """scipy.optimize bounds: one (lower, upper) pair per coordinate, None where unbounded."""
        return [(lo if np.isfinite(lo) else None, hi if np.isfinite(hi) else None)
                for lo, hi in zip(self.lower, self.upper)]

    def scale_into(self, values: np.ndarray) -> np.ndarray:
        """``values`` (n,) scaled by the largest s in [0, 1] that puts them inside a box around 0.

        For velocity limits: the direction of the velocity is kept and no coordinate
        exceeds its limit (clamping coordinate by coordinate would turn it).
        """
        values = np.asarray(values, dtype=float)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratios = np.where(values > 0, self.upper / values, np.where(values < 0, self.lower / values, np.inf))
        return values * float(np.clip(np.min(ratios, initial=np.inf), 0.0, 1.0))


def _numbers(value: object, what: str) -> np.ndarray:
    """``value`` as a float array, else LimitError naming ``what``; a bool is not a number."""
    try:
        if isinstance(value, bool):
            raise TypeError
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise LimitError(f"{what} must be numbers [rad or m, rad/s or m/s], got {value!r}") from None


def _number(value: object, what: str) -> float:
    """``value`` as one float, else LimitError naming ``what``."""
    number = _numbers(value, what)
    if number.ndim != 0:
        raise LimitError(f"{what} must be one number [rad or m, rad/s or m/s], got {value!r}")
    return float(number)
