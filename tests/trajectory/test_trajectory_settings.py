"""A motion described by numbers (uvms.trajectory.settings): checked where it is made, built from the start pose."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from uvms.errors import UVMSError
from uvms.trajectory import PathTrajectory, TrajectorySettings, VelocityRamps


def test_a_circle_from_the_start_pose_and_its_laps():
    """A circle of radius 1 about start + (1, 0, 0), two laps in 10 s (the quintic law): the start and the
    orientation are the frame's when not given; at half the time the point is back at the start (one lap done)."""
    start = pin.SE3(pin.rpy.rpyToMatrix(0.1, 0.2, 0.3), np.array([0.5, -1.0, 2.0]))
    settings = TrajectorySettings(center_offset=(1.0, 0.0, 0.0), laps=2.0, duration=10.0, law="quintic")
    trajectory = settings.trajectory(start)
    assert isinstance(trajectory, PathTrajectory)
    np.testing.assert_allclose(trajectory(0.0).pose.translation, start.translation, atol=1e-12)
    np.testing.assert_allclose(trajectory(5.0).pose.translation, start.translation, atol=1e-9)
    np.testing.assert_allclose(trajectory(10.0).pose.rotation, start.rotation, atol=1e-12)
    assert settings.law_of(2 * np.pi).distance == pytest.approx(4 * np.pi)


def test_a_hold_keeps_the_given_start():
    settings = TrajectorySettings(type="hold", start=(1.0, 2.0, 3.0), orientation=(0.0, 0.0, 0.5), duration=4.0)
    trajectory = settings.trajectory(pin.SE3.Identity())
    assert isinstance(trajectory, VelocityRamps)
    np.testing.assert_allclose(trajectory(3.0).pose.translation, [1.0, 2.0, 3.0], atol=1e-12)
    np.testing.assert_allclose(pin.rpy.matrixToRpy(trajectory(3.0).pose.rotation), [0.0, 0.0, 0.5], atol=1e-12)


@pytest.mark.parametrize(("values", "message"), [
    (dict(center=(1.0, 2.0)), "^center must have 3 numbers, got 2"),
    (dict(), "^center or center_offset is needed by a circle"),
    (dict(type="line"), "^end or end_offset is needed by a line"),
    (dict(type="ramps", velocity=(0.1, 0.0, 0.0)), r"^accel_time \(the ramp time\) in \(0, duration/2\] = \(0, 5\]"),
    (dict(center=(1.0, 0.0, 0.0), speed=0.5, laps=2.0), "^speed and laps are both set"),
    (dict(center=(1.0, 0.0, 0.0), speed=0.5, law="cubic"), "^speed is the cruise speed of the trapezoid law"),
    (dict(law="linear"), "^law must be one of trapezoid, cubic, quintic"),
])
def test_what_a_motion_misses_is_refused_when_it_is_made_naming_the_field(values, message):
    with pytest.raises(UVMSError, match=message):
        TrajectorySettings(duration=10.0, **values)


def test_a_vector_left_unused_by_the_type_is_not_checked():
    """As the scenario reader always did: a line's leftover circle centre is not its concern."""
    TrajectorySettings(type="line", end_offset=(1.0, 0.0, 0.0), center=(1.0, 2.0), duration=1.0)
