"""Time laws, paths and pose trajectories: values at known points and derivatives against finite differences."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from uvms import UVMSError
from uvms.trajectory import CirclePath, LinePath, PathTrajectory, PolynomialLaw, SE3Trajectory, TrapezoidLaw

LAWS = [
    TrapezoidLaw(speed=0.5, duration=190.0, accel_time=5.0),
    TrapezoidLaw.from_distance(2 * np.pi, duration=10.0),
    PolynomialLaw(distance=3.0, duration=10.0, degree=3),
    PolynomialLaw(distance=-2.0, duration=4.0, degree=5),
]


@pytest.mark.parametrize("law", LAWS)
def test_time_law_derivatives_and_ends(law):
    assert law(0.0).s == 0.0 and law(law.duration).s == pytest.approx(law.distance)
    for t in np.linspace(0.013, law.duration - 0.013, 37):
        h = 1e-6
        assert (law(t + h).s - law(t - h).s) / (2 * h) == pytest.approx(law(t).ds, abs=1e-7)
        assert (law(t + h).ds - law(t - h).ds) / (2 * h) == pytest.approx(law(t).dds, abs=1e-6)


def test_trapezoid_of_hoang2011():
    law = LAWS[0]
    assert law.distance == pytest.approx(0.5 * 185.0)
    assert law(2.5).ds == pytest.approx(0.25) and law(100.0).ds == 0.5 and law(187.5).ds == pytest.approx(0.25)
    assert law(5.0).s == pytest.approx(1.25)


def test_quintic_and_cubic_boundary_conditions():
    cubic, quintic = LAWS[2], LAWS[3]
    assert cubic(1e-12).ds == pytest.approx(0.0, abs=1e-9) and cubic(10 - 1e-12).ds == pytest.approx(0.0, abs=1e-9)
    assert quintic(1e-12).dds == pytest.approx(0.0, abs=1e-9) and quintic(4 - 1e-12).dds == pytest.approx(0.0, abs=1e-9)


def test_circle_geometry_and_trajectory_derivatives():
    path = CirclePath(center=[0.0, 2.0, 0.0], start=[0.0, -2.0, 0.0])
    assert path.radius == 4.0 and path.length == pytest.approx(8 * np.pi)
    assert np.allclose(path(0.0).point, [0, -2, 0]) and np.allclose(path(path.length / 2).point, [0, 6, 0])
    trajectory = PathTrajectory(path, LAWS[0], orientation=[0.0, 0.0, 1.0])
    for t in (3.0, 50.0, 188.0):
        h = 1e-5
        velocity = (trajectory(t + h).pose.translation - trajectory(t - h).pose.translation) / (2 * h)
        acceleration = (trajectory(t + h).twist[:3] - trajectory(t - h).twist[:3]) / (2 * h)
        assert np.allclose(trajectory(t).twist[:3], velocity, atol=1e-8)
        assert np.allclose(trajectory(t).acceleration[:3], acceleration, atol=1e-6)
        assert np.linalg.norm(trajectory(t).pose.translation - [0, 2, 0]) == pytest.approx(4.0)
        assert pin.rpy.matrixToRpy(trajectory(t).pose.rotation)[2] == pytest.approx(1.0)
    with pytest.raises(UVMSError):
        CirclePath([0, 0, 0], [0, 0, 1.0])  # start off the plane normal to z


def test_line_and_se3_interpolation():
    law = PolynomialLaw(distance=1.0, duration=2.0, degree=5)
    start, end = pin.SE3(np.eye(3), np.zeros(3)), pin.SE3(pin.rpy.rpyToMatrix(0.3, -0.2, 1.0), np.array([1.0, 2.0, -0.5]))
    trajectory = SE3Trajectory(start, end, law)
    assert np.allclose(trajectory(0.0).pose.homogeneous, start.homogeneous)
    assert np.allclose(trajectory(2.0).pose.homogeneous, end.homogeneous)
    t, h = 0.7, 1e-6
    plus, minus = trajectory(t + h).pose, trajectory(t - h).pose
    omega = pin.log3(plus.rotation @ minus.rotation.T) / (2 * h)
    assert np.allclose(trajectory(t).twist[3:], omega, atol=1e-7)
    assert np.allclose(trajectory(t).twist[:3], (plus.translation - minus.translation) / (2 * h), atol=1e-7)
    line = LinePath([0, 0, 0], [3.0, 4.0, 0.0])
    assert line.length == 5.0 and np.allclose(line(2.5).point, [1.5, 2.0, 0.0])
