"""Cartesian trajectories: geometric paths p(s) composed with time laws into pose trajectories.

A path gives the point p(s) with dp/ds and d2p/ds2; composed with a time law
s(t) it gives the position, velocity and acceleration of the desired
end-effector motion; a constant or SE(3)-interpolated orientation completes the pose.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..errors import UVMSError
from ..robot.conventions import pose_from_xyzrpy
from .laws import PolynomialLaw, TimeLaw


@dataclass(frozen=True)
class PathSample:
    """p(s) (3,), dp/ds (3,), d2p/ds2 (3,)."""

    point: np.ndarray
    tangent: np.ndarray
    curvature: np.ndarray


@dataclass(frozen=True)
class PathSamples:
    """A path at N arc lengths: p(s) (N, 3) [m], dp/ds (N, 3), d2p/ds2 (N, 3) [1/m]."""

    points: np.ndarray
    tangents: np.ndarray
    curvatures: np.ndarray

    def sample(self, index: int) -> PathSample:
        """The sample of row ``index``."""
        return PathSample(self.points[index], self.tangents[index], self.curvatures[index])


def first_of(path, s: float) -> PathSample:
    """A path's sample at one arc length s [m] (its ``at`` over one value)."""
    return path.at(np.array([float(s)])).sample(0)


class CirclePath:
    """Circle through ``start`` around ``center`` in the plane normal to ``normal`` (counter-clockwise about it).

    Args:
        center: (3,) [m]; start: (3,) [m], radius = ``|start - center|`` > 0.
        normal: (3,) plane normal (right-hand rule gives the direction of travel).
    """

    def __init__(self, center: np.ndarray, start: np.ndarray, normal: np.ndarray = (0.0, 0.0, 1.0)) -> None:
        self.center = np.asarray(center, dtype=float)
        start = np.asarray(start, dtype=float)
        normal = np.asarray(normal, dtype=float)
        radial = start - self.center
        self.radius = float(np.linalg.norm(radial))
        if self.radius == 0 or np.linalg.norm(normal) == 0:
            raise UVMSError("a circle needs start != center and a non-zero normal")
        normal = normal / np.linalg.norm(normal)
        if abs(radial @ normal) > 1e-9 * self.radius:
            raise UVMSError("the circle's start point must lie in the plane through the centre normal to `normal`")
        self.e1 = radial / self.radius
        self.e2 = np.cross(normal, self.e1)

    @property
    def length(self) -> float:
        """Circumference [m]."""
        return 2 * np.pi * self.radius

    def __call__(self, s: float) -> PathSample:
        """The sample at arc length s [m] (:meth:`at`)."""
        return first_of(self, s)

    def at(self, s: np.ndarray) -> PathSamples:
        """p = center + r (cos a e1 + sin a e2), its tangent and curvature vectors at the arc lengths s (N,) [m],
        a = s / r."""
        radius = self.radius
        angle = s / radius
        c, sn = np.cos(angle)[:, None], np.sin(angle)[:, None]  # (N, 1)
        center, e1, e2 = self.center, self.e1, self.e2
        return PathSamples(center + radius * (c * e1 + sn * e2), -sn * e1 + c * e2, (-c * e1 - sn * e2) / radius)


class LinePath:
    """Straight segment from ``start`` to ``end``, parametrized by arc length."""

    def __init__(self, start: np.ndarray, end: np.ndarray) -> None:
        self.start = np.asarray(start, dtype=float)
        delta = np.asarray(end, dtype=float) - self.start
        self.length = float(np.linalg.norm(delta))
        if self.length == 0:
            raise UVMSError("a line needs start != end")
        self.direction = delta / self.length

    def __call__(self, s: float) -> PathSample:
        """The sample at arc length s [m] (:meth:`at`)."""
        return first_of(self, s)

    def at(self, s: np.ndarray) -> PathSamples:
        """p = start + s d, d, 0 at the arc lengths s (N,) [m]."""
        count = len(s)
        return PathSamples(self.start + s[:, None] * self.direction, np.tile(self.direction, (count, 1)),
                           np.zeros((count, 3)))


class PointPath:
    """A path that stays at ``point`` (3,) [m] whatever s (a trajectory that holds a pose)."""

    def __init__(self, point: np.ndarray) -> None:
        self.point = np.array(point, dtype=float)

    def __call__(self, s: float) -> PathSample:
        """The sample at arc length s [m] (:meth:`at`)."""
        return first_of(self, s)

    def at(self, s: np.ndarray) -> PathSamples:
        """The point, zero tangent and curvature at each of the arc lengths s (N,)."""
        count = len(s)
        return PathSamples(np.tile(self.point, (count, 1)), np.zeros((count, 3)), np.zeros((count, 3)))


@dataclass(frozen=True)
class PoseSample:
    """Desired pose, twist [v; omega] (6,) and acceleration (6,) in world axes."""

    pose: pin.SE3
    twist: np.ndarray
    acceleration: np.ndarray


@dataclass(frozen=True)
class PoseSamples:
    """A pose trajectory at N times: positions (N, 3) [m], rotations (N, 3, 3), twists [v; omega] (N, 6) and
    accelerations (N, 6) in world axes, and the roll-pitch-yaw of each rotation (N, 3) [rad] (given by a producer
    that knows them, else ``matrixToRpy`` of each row) (read-only arrays: a sample's arrays are views of them)."""

    translations: np.ndarray
    rotations: np.ndarray
    twists: np.ndarray
    accelerations: np.ndarray
    rpy: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.rpy is None:
            rpy = np.array([pin.rpy.matrixToRpy(rotation) for rotation in self.rotations]).reshape(-1, 3)
            object.__setattr__(self, "rpy", rpy)
        for array in (self.translations, self.rotations, self.twists, self.accelerations, self.rpy):
            array.flags.writeable = False

    def __len__(self) -> int:
        return len(self.translations)

    def sample(self, index: int) -> PoseSample:
        """The sample of row ``index``."""
        return PoseSample(pin.SE3(self.rotations[index], self.translations[index]), self.twists[index],
                          self.accelerations[index])


class PathTrajectory:
    """A path travelled with a time law, at a constant orientation.

    Args:
        path: CirclePath, LinePath, PointPath or any path with ``at(s (N,)) -> PathSamples``.
        law: a TimeLaw giving s(t).
        orientation: constant rotation (3x3) or [roll, pitch, yaw] [rad].
    """

    def __init__(self, path, law: TimeLaw, orientation: np.ndarray | Sequence[float] = (0.0, 0.0, 0.0)) -> None:
        self.path, self.law = path, law
        orientation = np.asarray(orientation, dtype=float)
        self.rotation = orientation if orientation.shape == (3, 3) else pin.rpy.rpyToMatrix(*orientation)
        self.duration = law.duration

    def __call__(self, t: float) -> PoseSample:
        """The sample at t [s] (:meth:`at`)."""
        return self.at(np.array([float(t)])).sample(0)

    def at(self, times: np.ndarray) -> PoseSamples:
        """The samples at the times (N,) [s], the path evaluated once over all of them."""
        s, ds, dds = self.law.at(np.asarray(times, dtype=float))
        ds_squared = np.array([rate**2 for rate in ds.tolist()], dtype=float)  # Python's power, as one sample's
        path = self.path.at(s)
        count = len(times)
        twists, accelerations = np.zeros((count, 6)), np.zeros((count, 6))  # constant orientation: no angular parts
        twists[:, :3] = path.tangents * ds[:, None]
        accelerations[:, :3] = path.tangents * dds[:, None] + path.curvatures * ds_squared[:, None]
        return PoseSamples(path.points, np.broadcast_to(self.rotation, (count, 3, 3)), twists, accelerations,
                           np.broadcast_to(pin.rpy.matrixToRpy(self.rotation), (count, 3)))  # one orientation


class SE3Trajectory:
    """Screw-free SE(3) interpolation: position on a straight line, rotation by the SO(3) geodesic.

    M(s) = (R0 exp(s log(R0^T R1)), p0 + s (p1 - p0)), s = law(t) / law.distance in [0, 1]
    (the ``ctraj`` of the robotics toolboxes).
    """

    def __init__(self, start: pin.SE3 | Sequence[float], end: pin.SE3 | Sequence[float], law: TimeLaw) -> None:
        self.start = start if isinstance(start, pin.SE3) else pose_from_xyzrpy(np.asarray(start, dtype=float))
        self.end = end if isinstance(end, pin.SE3) else pose_from_xyzrpy(np.asarray(end, dtype=float))
        if law.distance == 0:
            raise UVMSError("an SE(3) interpolation needs a time law with a non-zero distance")
        self.law = law
        self.duration = law.duration
        self.rotation_log = pin.log3(self.start.rotation.T @ self.end.rotation)  # body axes of the start
        self.translation = self.end.translation - self.start.translation

    def __call__(self, t: float) -> PoseSample:
        timing = self.law(t)
        fraction, rate, rate2 = (timing.s / self.law.distance, timing.ds / self.law.distance,
                                 timing.dds / self.law.distance)
        rotation = self.start.rotation @ pin.exp3(fraction * self.rotation_log)
        omega_world = self.start.rotation @ self.rotation_log  # constant axis: R0 log, in world axes
        pose = pin.SE3(rotation, self.start.translation + fraction * self.translation)
        twist = np.concatenate([rate * self.translation, rate * omega_world])
        acceleration = np.concatenate([rate2 * self.translation, rate2 * omega_world])
        return PoseSample(pose, twist, acceleration)


def hold(pose: pin.SE3, duration: float) -> PathTrajectory:
    """A trajectory that stays at ``pose`` for ``duration`` [s]."""
    law = PolynomialLaw(distance=0.0, duration=duration, degree=5)
    return PathTrajectory(PointPath(pose.translation), law, pose.rotation)

