"""An end-effector motion described by numbers: the path (circle, line, pose, ramps or hold) and its time law.

One frozen object, checked where it is made (a scenario's ``[trajectory]`` is made from it when the file is read:
its keys are these fields, its defaults these defaults), that builds the trajectory once the frame's pose at the
start is known (:meth:`TrajectorySettings.trajectory`).
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np
import pinocchio as pin

from ..errors import UVMSError
from .cartesian import CirclePath, LinePath, PathTrajectory, SE3Trajectory
from .laws import PolynomialLaw, TimeLaw, TrapezoidLaw
from .ramps import VelocityRamps

#: The trajectory types: a circle, a line, a pose (a line and the SO(3) geodesic between two orientations),
#: velocity ramps, or the start pose held (station keeping).
TRAJECTORY_TYPES = ("circle", "line", "pose", "ramps", "hold")
#: The time laws along a path.
LAWS = ("trapezoid", "cubic", "quintic")


@dataclass(frozen=True, kw_only=True)
class TrajectorySettings:
    """The desired motion of a frame, in world axes (ENU); what is not given comes from the frame's pose at the start.

    Attributes:
        type: one of :data:`TRAJECTORY_TYPES`.
        start: start point (3,) [m]; (): where the frame is at the start.
        center, center_offset: a circle's centre [m], absolute or relative to ``start``; normal: its plane's normal.
        end, end_offset: a line's or pose's end point [m], absolute or relative to ``start``.
        orientation: constant orientation, roll-pitch-yaw [rad]; (): the frame's at the start.
        end_orientation: a pose's orientation at the end, roll-pitch-yaw [rad]; (): ``orientation``.
        law: the time law along the path (:data:`LAWS`).
        speed: the trapezoid's cruise speed [m/s] (the distance is then speed x duration); 0: the path (or its
            ``laps``) covered in ``duration``.
        laps: a circle's laps in ``duration``; 0: one pass.
        duration: the motion's length [s] (> 0).
        accel_time: the trapezoid's or the ramps' acceleration (and deceleration) time [s].
        velocity: the ramps' cruise velocity (3,) [m/s, world].

    Raises:
        UVMSError: a vector that is not 3 numbers, a type or law not known, or what the type needs and misses (each
            message begins with the field it is about).
    """

    type: str = "circle"
    start: tuple[float, ...] = ()
    center: tuple[float, ...] = ()
    center_offset: tuple[float, ...] = ()
    normal: tuple[float, ...] = (0.0, 0.0, 1.0)
    end: tuple[float, ...] = ()
    end_offset: tuple[float, ...] = ()
    orientation: tuple[float, ...] = ()
    end_orientation: tuple[float, ...] = ()
    law: str = "trapezoid"
    speed: float = 0.0
    laps: float = 0.0
    duration: float
    accel_time: float = 0.0
    velocity: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        for name, valid in (("type", TRAJECTORY_TYPES), ("law", LAWS)):
            if getattr(self, name) not in valid:
                raise UVMSError(f"{name} must be one of {', '.join(valid)}, got {getattr(self, name)!r}")
        for name in ("start", "orientation"):
            self._vector(name)
        kind = self.type
        if kind == "hold":
            return
        if kind == "ramps":
            if not self.velocity:
                raise UVMSError("velocity (the cruise velocity [m/s], world axes) is needed by a ramps trajectory")
            if not 0 < self.accel_time <= self.duration / 2:
                raise UVMSError(f"accel_time (the ramp time) in (0, duration/2] = (0, {self.duration / 2:g}] s is "
                                f"needed by a ramps trajectory, got {self.accel_time:g}")
            self._vector("velocity")
            return
        if kind == "circle":
            if not (self.center or self.center_offset):
                raise UVMSError("center or center_offset is needed by a circle trajectory")
            self._vector("center" if self.center else "center_offset")
            self._vector("normal")
        else:
            if not (self.end or self.end_offset):
                raise UVMSError(f"end or end_offset is needed by a {kind} trajectory")
            self._vector("end" if self.end else "end_offset")
        if self.speed and self.laps:
            raise UVMSError("speed and laps are both set, but the speed fixes the distance (speed x duration) and "
                            "the laps would be ignored: keep laps (the circle that many times in duration) or speed "
                            "(the trapezoid's cruise speed [m/s]), not both")
        if self.speed and self.law != "trapezoid":
            raise UVMSError(f"speed is the cruise speed of the trapezoid law, and law = {self.law!r} would ignore it: "
                            f"set law = 'trapezoid' or remove speed (the {self.law} law covers the path, or its laps, "
                            f"in duration)")
        if kind == "pose":
            self._vector("end_orientation")

    @classmethod
    def names(cls) -> tuple[str, ...]:
        """The settings' names, in their order."""
        return tuple(item.name for item in fields(cls))

    def _vector(self, name: str) -> np.ndarray | None:
        """The field ``name`` as an array (3,), None when empty."""
        values = getattr(self, name)
        if not values:
            return None
        if len(values) != 3:
            raise UVMSError(f"{name} must have 3 numbers, got {len(values)}")
        return np.array(values, dtype=float)

    def trajectory(self, start_pose: pin.SE3) -> PathTrajectory | SE3Trajectory | VelocityRamps:
        """The motion of the frame whose pose at the start is ``start_pose`` (world_M_frame): the start and the
        orientation default to it."""
        start = self._vector("start")
        start = start_pose.translation.copy() if start is None else start
        orientation = self._vector("orientation")
        orientation = pin.rpy.matrixToRpy(start_pose.rotation) if orientation is None else orientation
        kind, duration = self.type, self.duration
        if kind == "hold":  # the start pose held for the duration (station keeping)
            return VelocityRamps.trapezoid(start, np.zeros(3), duration, duration / 2,
                                           rotation=pin.rpy.rpyToMatrix(*orientation))
        if kind == "ramps":
            return VelocityRamps.trapezoid(start, self._vector("velocity"), duration, self.accel_time,
                                           rotation=pin.rpy.rpyToMatrix(*orientation))
        if kind == "circle":
            center = self._vector("center")
            center = start + self._vector("center_offset") if center is None else center
            path = CirclePath(center, start, self._vector("normal"))
        else:
            end = self._vector("end")
            path = LinePath(start, start + self._vector("end_offset") if end is None else end)
        law = self.law_of(path.length)
        if kind == "pose":
            end_orientation = self._vector("end_orientation")
            return SE3Trajectory(np.concatenate([start, orientation]),
                                 np.concatenate([path(path.length).point,
                                                 orientation if end_orientation is None else end_orientation]), law)
        return PathTrajectory(path, law, orientation)

    def law_of(self, path_length: float) -> TimeLaw:
        """The time law over a path of ``path_length`` [m]: the trapezoid from a speed, or any law from the laps
        (circle) or the path's length."""
        duration, accel_time = self.duration, self.accel_time
        distance = self.laps * path_length if self.laps else path_length
        if self.law == "trapezoid":
            if self.speed:
                return TrapezoidLaw(speed=self.speed, duration=duration, accel_time=accel_time)
            return TrapezoidLaw.from_distance(distance, duration, accel_time)
        return PolynomialLaw(distance=distance, duration=duration, degree=3 if self.law == "cubic" else 5)


__all__ = ["LAWS", "TRAJECTORY_TYPES", "TrajectorySettings"]
