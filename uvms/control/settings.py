"""The actuated chain's settings: the vehicle's velocity and pose loops, the allocation, the arm's coordination.

One frozen object that :func:`uvms.control.station.actuated_control` takes whole; a scenario's
``[vehicle_control]`` section is made from it (its keys are these fields, its defaults these defaults).
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from ..errors import SolverInputError
from ..robot.conventions import AXIS_NAMES

#: Default natural frequency omega [rad/s] of the velocity loop per body axis (surge, sway, heave, roll, pitch,
#: yaw): the BlueROV2's hand-tuned surge loop (2.75 rad/s) and roll loop (5.0 rad/s); below the thrusters' 1/tau
#: (10 rad/s for tau = 0.1 s), above the pose loop's 1.5 1/s. Faster translation (3 rad/s) costs the BlueROV2 its
#: attitude when the thrusters saturate without allocation priorities (0.15 instead of 0.05 rad in a 1 m/s current).
DEFAULT_BANDWIDTH = (2.75, 2.75, 2.75, 5.0, 5.0, 5.0)
#: Default damping ratio zeta per body axis: near-critical in translation (the BlueROV2's surge loop: 0.92),
#: overdamped in rotation (its roll loop: 1.7), so the attitude does not overshoot.
DEFAULT_DAMPING_RATIO = (0.9, 0.9, 0.9, 1.5, 1.5, 1.5)
#: Default time constant T [s] of the disturbance observer's low-pass: the thrusters' (0.1 s on the BlueROV2).
DEFAULT_DISTURBANCE_TIME_CONSTANT = 0.1

Gain = float | tuple[float, ...]


def gain_vector(value: float | np.ndarray, what: str, size: int = 6, *, positive: bool = False) -> np.ndarray:
    """A diagonal gain (size,) >= 0 (``positive``: > 0, e.g. a bandwidth) from a number or ``size`` numbers.

    Raises:
        SolverInputError: not finite, negative (``positive``: not > 0) or of the wrong size.
    """
    array = np.broadcast_to(np.asarray(value, dtype=float), (size,)).copy() if np.ndim(value) == 0 \
        else np.asarray(value, dtype=float)
    if array.shape != (size,) or not np.all(np.isfinite(array)) or np.any(array <= 0 if positive else array < 0):
        raise SolverInputError(f"{what} must be a number or {size} numbers {'> 0' if positive else '>= 0'} (a "
                               f"diagonal gain, one per axis), got {value!r}")
    return array


@dataclass(frozen=True, kw_only=True)
class ActuatedSettings:
    """How the actuated chain holds the vehicle and coordinates the arm (the defaults hold the BlueROV2 + Alpha 5 in
    a 0.3 m/s current to 5 cm and a 1.9 t RexROV-sized vehicle to 3 mm: tests/control/test_vehicle_gains.py).

    A gain is one number (every axis) or 6, one per body axis (FLU: x, y, z, roll, pitch, yaw). Every value is
    checked here, when the settings are made (a scenario's ``[vehicle_control]``: when the file is read).

    Attributes:
        kp: velocity loop's proportional gains [N s/m, N m s/rad]; None: kp = 2 zeta omega M_ii from
            ``bandwidth``, ``damping_ratio`` and the vehicle's inertia M_ii at the station
            (:func:`uvms.control.vehicle.velocity_gains`).
        ki: its integral gains [N/m, N m/rad]; None: ki = omega^2 M_ii.
        bandwidth: the velocity loop's closed-loop bandwidth omega [rad/s] (> 0).
        damping_ratio: its damping ratio zeta (> 0).
        pose_gains: the pose loop's gains [1/s].
        max_speed: bound of the pose loop's velocity reference [m/s, rad/s]; None: none.
        priorities: the allocation's groups of wrench axes, highest first (e.g. ``(("roll", "pitch", "yaw", "z"),
            ("x", "y"))``); (): one group of all six axes.
        coordination: solve the arm again with the measured vehicle velocity
            (:class:`uvms.control.coordination.CoordinatedControl`).
        saturation_feedback: bound the vehicle's part of the next reference by what the allocation achieved.
        knows_current: the controller's model includes the plant's current; False: the integral learns it.
        arm_feedforward: feed the arm's reaction into the velocity loop's model feedforward.
        acceleration_feedforward: feed the reference's acceleration through the model's inertia.
        servo_compensation: command the arm's servos so that they reach the asked rate by the end of the step.
        disturbance_time_constant: the disturbance observer's time constant T [s]; 0: none.
        tightening: move the enforced inequalities' bounds inward by their measured tracking error
            (:mod:`uvms.control.tightening`).
    """

    kp: Gain | None = None
    ki: Gain | None = None
    bandwidth: Gain = DEFAULT_BANDWIDTH
    damping_ratio: Gain = DEFAULT_DAMPING_RATIO
    pose_gains: Gain = 1.5
    max_speed: Gain | None = 0.5
    priorities: tuple[tuple[str, ...], ...] = ()
    coordination: bool = True
    saturation_feedback: bool = False
    knows_current: bool = False
    arm_feedforward: bool = True
    acceleration_feedforward: bool = True
    servo_compensation: bool = True
    disturbance_time_constant: float = DEFAULT_DISTURBANCE_TIME_CONSTANT
    tightening: bool = True

    def __post_init__(self) -> None:
        for name in ("kp", "ki", "bandwidth", "damping_ratio", "pose_gains", "max_speed"):
            if isinstance(getattr(self, name), list):  # frozen: a list given is kept as a tuple
                object.__setattr__(self, name, tuple(getattr(self, name)))
        for name in ("kp", "ki", "pose_gains", "max_speed"):  # >= 0 (None: derived, or no bound)
            if getattr(self, name) is not None:
                gain_vector(getattr(self, name), name)
        for name in ("bandwidth", "damping_ratio"):
            gain_vector(getattr(self, name), name, positive=True)
        gain_vector(self.disturbance_time_constant, "disturbance_time_constant", 1)
        groups = self.priorities
        if not all(isinstance(group, (list, tuple)) and group and all(axis in AXIS_NAMES for axis in group)
                   for group in groups):
            raise SolverInputError(f"priorities must be a list of groups of wrench axes among {', '.join(AXIS_NAMES)}, "
                                   f"highest priority first, e.g. [['yaw', 'z', 'roll', 'pitch'], ['x', 'y']]; got "
                                   f"{groups!r}")
        object.__setattr__(self, "priorities", tuple(tuple(group) for group in groups))

    @classmethod
    def names(cls) -> tuple[str, ...]:
        """The settings' names, in their order."""
        return tuple(item.name for item in fields(cls))


__all__ = ["DEFAULT_BANDWIDTH", "DEFAULT_DAMPING_RATIO", "DEFAULT_DISTURBANCE_TIME_CONSTANT", "ActuatedSettings"]
