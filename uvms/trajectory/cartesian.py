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

from ..robot.conventions import pose_from_xyzrpy
from ..errors import UVMSError
from .laws import PolynomialLaw, TimeLaw


@dataclass(frozen=True)
class PathSample:
    """p(s) (3,), dp/ds (3,), d2p/ds2 (3,)."""

    point: np.ndarray
    tangent: np.ndarray
    curvature: np.ndarray


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
        # Python floats of the constant vectors: a sample's 3-vectors in float arithmetic cost half as much as
        # thirteen numpy operations on them, with the same IEEE operations in the same order (the same bits)
        self._columns = tuple(zip(self.center.tolist(), self.e1.tolist(), self.e2.tolist()))

    @property
    def length(self) -> float:
        """Circumference [m]."""
        return 2 * np.pi * self.radius

    def __call__(self, s: float) -> PathSample:
        """p = center + r (cos a e1 + sin a e2), its tangent and curvature vectors at arc length s [m], a = s / r."""
        radius = self.radius
        angle = s / radius
        c, sn = float(np.cos(angle)), float(np.sin(angle))
        columns = self._columns  # (center_i, e1_i, e2_i) for i = x, y, z
        return PathSample(
            np.array([center + radius * (c * e1 + sn * e2) for center, e1, e2 in columns]),
            np.array([-sn * e1 + c * e2 for _, e1, e2 in columns]),
            np.array([(-c * e1 - sn * e2) / radius for _, e1, e2 in columns]),
        )


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
        return PathSample(self.start + s * self.direction, self.direction.copy(), np.zeros(3))


@dataclass(frozen=True)
class PoseSample:
    """Desired pose, twist [v; omega] (6,) and acceleration (6,) in world axes."""

    pose: pin.SE3
    twist: np.ndarray
    acceleration: np.ndarray


class PathTrajectory:
    """A path travelled with a time law, at a constant orientation.

    Args:
        path: CirclePath, LinePath or any callable s -> PathSample.
        law: a TimeLaw giving s(t).
        orientation: constant rotation (3x3) or [roll, pitch, yaw] [rad].
    """

    def __init__(self, path, law: TimeLaw, orientation: np.ndarray | Sequence[float] = (0.0, 0.0, 0.0)) -> None:
        self.path, self.law = path, law
        orientation = np.asarray(orientation, dtype=float)
        self.rotation = orientation if orientation.shape == (3, 3) else pin.rpy.rpyToMatrix(*orientation)
        self.duration = law.duration

    def __call__(self, t: float) -> PoseSample:
        timing = self.law(t)
        sample = self.path(timing.s)
        twist, acceleration = np.zeros(6), np.zeros(6)  # constant orientation: no angular parts
        twist[:3] = sample.tangent * timing.ds
        acceleration[:3] = sample.tangent * timing.dds + sample.curvature * timing.ds**2
        return PoseSample(pin.SE3(self.rotation, sample.point), twist, acceleration)


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
    return PathTrajectory(lambda s: PathSample(pose.translation.copy(), np.zeros(3), np.zeros(3)), law, pose.rotation)

