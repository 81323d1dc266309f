"""Joint position limits as an inequality objective (one row per limited arm coordinate), over a :class:`Limit`."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from ...errors import ObjectiveError
from ...robot.configuration import Configuration
from ...robot.limits import Limit
from ...robot.robot import Robot
from .base import Inequality, InequalityRows, finite_number

#: The band is capped at this fraction of each joint's valid range (a narrow jaw next to wide joints).
BAND_FRACTION_CAP = 0.25


class JointLimits(Inequality):
    """Arm joints within their position limits, ``margin`` inside them, activated across ``band``.

    Rows: the arm coordinates with finite limits whose value q holds itself (continuous joints, stored as
    (cos, sin), have none). x = q_i, J = the unit row of v_i. The valid set is
    [q_min + margin, q_max - margin] (``limit.take(rows).shrink(margin)``: the same :class:`Limit` the
    joint-limit potential and CLIK's clamping read); the activation rises from 0 at ``band`` inside it to 1
    at its border.
    The set-based solver also keeps the hard limits (q_min, q_max) by saturation; the QP hierarchy turns
    the valid set into hard velocity bounds.

    Args:
        robot: the model.
        margin: distance kept from each limit [rad or m], >= 0: one for every joint, or {joint name: margin}
            (joints not named keep 0), e.g. when revolute joints and a narrow prismatic jaw are limited together.
        band: activation band [rad or m] > 0, capped for each joint at a quarter of its valid range (the
            jaw of the Alpha 5 spans 0.015 m next to joints of several rad).
        gain: reference gain [1/s].
        joints: names of the joints to limit (default: every arm joint with finite limits).
        limit: position limits of the n_arm arm coordinates (default ``Limit.joint_positions(robot)``).
        shape: activation shape, "cosine" or "step".
        name: the name results report.

    Attributes:
        limit: the :class:`Limit` of the rows (k,), before the margin; valid: the one inside the margin.
        names: joint of each row (k,); v_index, q_index: its index in v and in q (k,).
        hard_lower, hard_upper: the limits before the margin (k,) (``limit.lower``, ``limit.upper``).
        margin: the margin of each row (k,) [rad or m].

    Raises:
        LimitError: a limit that is not the arm's positions, a bad margin or one that leaves no room.
        NameNotFound: a margin for a joint that is not limited here (the message lists the close ones).
        ObjectiveError: no limited joint, a joint without finite limits, a bad band, gain or shape.
    """

    type_name = "joint_limits"
    unit = "position in range [-]"
    bounds_joint_positions = True

    def __init__(self, robot: Robot, margin: float | Mapping[str, float] = 0.0, band: float = 0.2, gain: float = 1.0,
                 joints: Sequence[str] | None = None, limit: Limit | None = None, shape: str = "cosine",
                 name: str = "joint_limits") -> None:
        self.name = name
        self.robot = robot
        limit = Limit.arm(robot, limit, "position", name)
        rows = self._selected_rows(robot, limit, joints)
        self.limit = limit.take(rows)  # (k,) the hard limits of the rows
        self.valid = self.limit.shrink(margin, name)  # (k,) inside the margins
        self.margin = self.limit.margins(margin, name)
        self.names, self.q_index = self.limit.names, self.limit.q_index
        self.v_index = robot.n_vehicle + rows
        self.hard_lower, self.hard_upper = self.limit.lower, self.limit.upper
        lower, upper = self.valid.lower, self.valid.upper
        band = finite_number(band, f"{name}: band", positive=True)
        self._set_valid_set(lower, upper, np.minimum(band, BAND_FRACTION_CAP * (upper - lower)), gain, shape)
        self._jacobian = np.zeros((self.dim, robot.nv))
        self._jacobian[np.arange(self.dim), self.v_index] = 1.0

    @staticmethod
    def _selected_rows(robot: Robot, limit: Limit, joints: Sequence[str] | None) -> np.ndarray:
        """Indices of the arm coordinates limited: bounded, held in q, and among ``joints`` if given."""
        usable = limit.bounded & (limit.q_index >= 0)
        if joints is None:
            rows = np.flatnonzero(usable)
            if rows.size == 0:
                raise ObjectiveError(f"{robot.name} has no arm joint with finite position limits")
            return rows
        if isinstance(joints, str):
            joints = [joints]
        rows = []
        for joint in joints:
            robot.joint(joint)  # JointNotFound with the close names
            found = [i for i, owner in enumerate(limit.names) if owner == joint and usable[i]]
            if not found:
                raise ObjectiveError(f"joint {joint!r} is not an arm joint with finite position limits; those "
                                     f"are: {', '.join(sorted({limit.names[i] for i in np.flatnonzero(usable)}))}")
            rows.extend(found)
        return np.array(sorted(set(rows)), dtype=int)

    def shown(self, value: np.ndarray) -> np.ndarray:
        """The fraction of each joint's valid range (0: lower, 1: upper)."""
        return (value - self.lower) / (self.upper - self.lower)

    def value(self, state: Configuration) -> np.ndarray:
        return state.q[self.q_index]

    def jacobian(self, state: Configuration) -> np.ndarray:  # noqa: ARG002 - constant
        return self._jacobian

    def rows_into(self, state: Configuration, jacobian: np.ndarray, activation: np.ndarray,
                  reference: np.ndarray) -> InequalityRows:
        """:meth:`rows` written into a solver's stacked rows: the constant unit rows, x = q_i."""
        jacobian[:] = self._jacobian
        return self._rows_of(state.q[self.q_index], jacobian, activation, reference)
