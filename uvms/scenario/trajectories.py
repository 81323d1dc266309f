"""A scenario's ``[trajectory]``: the end effector's desired motion (circle, line, pose, ramps or hold) and its
time law."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ..errors import ScenarioError
from ..trajectory import CirclePath, LinePath, PathTrajectory, PolynomialLaw, SE3Trajectory, TrapezoidLaw, VelocityRamps
from .spec import TrajectorySpec


def vector(values: tuple[float, ...], size: int, name: str) -> np.ndarray:
    if len(values) != size:
        raise ScenarioError(f"trajectory.{name} must have {size} numbers, got {len(values)}")
    return np.array(values, dtype=float)


def make_trajectory(start_pose: pin.SE3, section: TrajectorySpec) -> PathTrajectory | SE3Trajectory | VelocityRamps:
    """The desired end-effector motion; start and orientation default to the frame's initial pose."""
    start = vector(section.start, 3, "start") if section.start else start_pose.translation.copy()
    orientation = (vector(section.orientation, 3, "orientation") if section.orientation
                   else pin.rpy.matrixToRpy(start_pose.rotation))
    kind = section.type
    if kind == "hold":  # the start pose held for the duration (station keeping)
        return VelocityRamps.trapezoid(start, np.zeros(3), section.duration, section.duration / 2,
                                       rotation=pin.rpy.rpyToMatrix(*orientation))
    if kind == "ramps":
        if not section.velocity:
            raise ScenarioError("a ramps trajectory needs trajectory.velocity (the cruise velocity [m/s], world axes)")
        if not 0 < section.accel_time <= section.duration / 2:
            raise ScenarioError(f"a ramps trajectory needs trajectory.accel_time (the ramp time) in (0, duration/2] = "
                                f"(0, {section.duration / 2:g}] s, got {section.accel_time:g}")
        return VelocityRamps.trapezoid(start, vector(section.velocity, 3, "velocity"), section.duration,
                                       section.accel_time, rotation=pin.rpy.rpyToMatrix(*orientation))
    if kind == "circle":
        if section.center:
            center = vector(section.center, 3, "center")
        elif section.center_offset:
            center = start + vector(section.center_offset, 3, "center_offset")
        else:
            raise ScenarioError("a circle trajectory needs trajectory.center or trajectory.center_offset")
        path = CirclePath(center, start, vector(section.normal, 3, "normal"))
    else:
        if section.end:
            end = vector(section.end, 3, "end")
        elif section.end_offset:
            end = start + vector(section.end_offset, 3, "end_offset")
        else:
            raise ScenarioError(f"a {kind} trajectory needs trajectory.end or trajectory.end_offset")
        path = LinePath(start, end)
    law = make_law(section, path.length)
    if kind == "pose":
        end_orientation = (vector(section.end_orientation, 3, "end_orientation") if section.end_orientation
                           else orientation)
        return SE3Trajectory(np.concatenate([start, orientation]),
                             np.concatenate([path(path.length).point, end_orientation]), law)
    return PathTrajectory(path, law, orientation)


def make_law(section: TrajectorySpec, path_length: float):
    """Time law: trapezoid from a speed, or any law from laps (circle) / the path length.

    Raises:
        ScenarioError: both trajectory.speed and trajectory.laps (a speed fixes the distance, the laps would be
            ignored), or a speed with a law other than the trapezoid (which alone has a cruise speed).
    """
    duration, accel_time = section.duration, section.accel_time
    if section.speed and section.laps:
        raise ScenarioError("trajectory.speed and trajectory.laps are both set, but the speed fixes the distance "
                            "(speed x duration) and the laps would be ignored: keep laps (the circle that many times "
                            "in trajectory.duration) or speed (the trapezoid's cruise speed [m/s]), not both")
    if section.speed and section.law != "trapezoid":
        raise ScenarioError(f"trajectory.speed is the cruise speed of the trapezoid law, and law = "
                            f"{section.law!r} would ignore it: set law = 'trapezoid' or remove speed (the "
                            f"{section.law} law covers the path, or its laps, in trajectory.duration)")
    distance = section.laps * path_length if section.laps else path_length
    if section.law == "trapezoid":
        if section.speed:
            return TrapezoidLaw(speed=section.speed, duration=duration, accel_time=accel_time)
        return TrapezoidLaw.from_distance(distance, duration, accel_time)
    return PolynomialLaw(distance=distance, duration=duration, degree=3 if section.law == "cubic" else 5)
