"""Trajectories (uvms.trajectory): time laws, paths and pose trajectories: values at known points and derivatives
against finite differences."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from uvms import UVMSError
from uvms.trajectory import (
    CirclePath,
    LinePath,
    PathTrajectory,
    PolynomialLaw,
    SE3Trajectory,
    TrapezoidLaw,
    ViaPointTrajectory,
    ctraj,
    jtraj,
)
from uvms.trajectory.joint import evaluate_polynomials

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


@pytest.mark.parametrize("law", LAWS)
def test_a_law_at_many_times_is_its_samples_one_by_one_bit_for_bit(law):
    """``at`` (the trapezoid's masks over 20,000 times and its phase boundaries) against one call per time."""
    rng = np.random.default_rng(4)
    ends = [0.0, law.duration, getattr(law, "accel_time", 0.0), law.duration - getattr(law, "accel_time", 0.0)]
    times = np.concatenate([rng.uniform(-1.0, law.duration + 1.0, 20000), ends, np.nextafter(ends, 1e9)])
    values = law.at(times)
    for name, column in zip(("s", "ds", "dds"), values):
        expected = np.array([getattr(law(t), name) for t in times.tolist()])
        assert np.array_equal(column, expected), name
    assert np.array_equal(law.at(times[:3])[0], values[0][:3])  # a few times: one call each, the same numbers


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
    tilted = CirclePath(center=[1.0, -2.0, 0.5], start=[1.0 + 0.6, -2.0, 0.5 - 0.8], normal=[0.8, 0.3, 0.6])
    for s in (0.0, 0.4, 2.5, -1.3):  # every component: p on the circle, p' and p'' by finite differences
        h, sample = 1e-4, tilted(s)
        assert np.linalg.norm(sample.point - [1.0, -2.0, 0.5]) == pytest.approx(1.0)
        np.testing.assert_allclose(sample.tangent, (tilted(s + h).point - tilted(s - h).point) / (2 * h), atol=1e-8)
        np.testing.assert_allclose(sample.curvature, (tilted(s + h).tangent - tilted(s - h).tangent) / (2 * h),
                                   atol=1e-8)
        assert sample.point @ [0.8, 0.3, 0.6] == pytest.approx(np.array([1.0, -2.0, 0.5]) @ [0.8, 0.3, 0.6])


def test_line_and_se3_interpolation():
    law = PolynomialLaw(distance=1.0, duration=2.0, degree=5)
    start, end = pin.SE3(np.eye(3), np.zeros(3)), pin.SE3(pin.rpy.rpyToMatrix(0.3, -0.2, 1.0),
                                                          np.array([1.0, 2.0, -0.5]))
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


# xiang2019 Table 2(a): joint positions [deg] of the left arm at t = 0, 10, 20, 30 s (rows: joints 1-4).
XIANG_POSITIONS_DEG = np.array([[0, -10, -75, -90], [0, 25, 20, 10], [0, 5, -10, -30], [0, 5, -15, -35]], float)
XIANG_TIMES = [0.0, 10.0, 20.0, 30.0]
# Table 2(b) and Table 3 as printed (interior via points 2 and 3).
XIANG_VELOCITY_TABLE = np.array([[-0.123, -0.131], [0.033, -0.025], [-0.016, -0.057], [-0.025, -0.065]])
XIANG_ACCELERATION_TABLE = np.array([[-0.0377, 0.0402], [0.01005, 0.00755], [0.01005, 0.0176], [0.01255, 0.0201]])


def xiang_trajectory(degree: int) -> ViaPointTrajectory:
    return ViaPointTrajectory(np.deg2rad(XIANG_POSITIONS_DEG).T, XIANG_TIMES, degree=degree)


def jumps_at(trajectory: ViaPointTrajectory, via: int) -> tuple[float, float, float]:
    """Largest change of q, qd, qdd at interior via point ``via``: end of the segment before vs start of the next."""
    duration = np.diff(trajectory.times)[via - 1]
    before = evaluate_polynomials(trajectory.coefficients[[via - 1]], np.array([duration]))
    after = evaluate_polynomials(trajectory.coefficients[[via]], np.array([0.0]))
    return tuple(float(np.abs(left - right).max()) for left, right in zip(before, after))


@pytest.mark.parametrize("degree", [3, 5])
def test_via_point_trajectory_passes_the_points_with_averaged_slopes(degree):
    trajectory = xiang_trajectory(degree)
    samples = trajectory(XIANG_TIMES)
    assert np.allclose(samples.q, np.deg2rad(XIANG_POSITIONS_DEG).T, atol=1e-14)
    # Via velocity = mean of the adjacent slopes, zero at both ends: joint 1 at via 2 is (-1 - 6.5) / 2 deg/s.
    assert np.rad2deg(samples.qd[:, 0]) == pytest.approx([0.0, -3.75, -4.0, 0.0], abs=1e-12)
    assert np.abs(samples.qd[[0, -1]]).max() < 1e-15
    dense = trajectory.sample(1e-3)
    inside = np.abs(dense.t[1:-1, None] - XIANG_TIMES).min(axis=1) > 1.5e-3  # not across a via point
    for name, x, dx in (("q", dense.q, dense.qd), ("qd", dense.qd, dense.qdd)):
        middle = 0.5 * (x[2:] - x[:-2]) / 1e-3
        assert np.allclose(middle[inside], dx[1:-1][inside], atol=1e-8), name  # derivatives are derivatives


def test_cubic_is_velocity_continuous_quintic_also_acceleration_continuous():
    cubic, quintic = xiang_trajectory(3), xiang_trajectory(5)
    for via in (1, 2):
        q_jump, qd_jump, qdd_jump = jumps_at(cubic, via)
        assert q_jump < 1e-14 and qd_jump < 1e-15
        assert qdd_jump > 1e-3  # the cubic's acceleration jumps (Fig. 5) ...
        assert max(jumps_at(quintic, via)) < 1e-14  # ... the quintic's does not (Fig. 6)
    assert np.abs(quintic([0.0, 30.0]).qdd).max() < 1e-15  # rest-to-rest: zero end accelerations
    via = quintic(XIANG_TIMES).qdd
    slopes = np.diff(quintic.velocities, axis=0) / 10.0
    assert np.allclose(via[1:-1], 0.5 * (slopes[:-1] + slopes[1:]), atol=1e-14)


def test_xiang_tables_are_peak_rates_of_rest_to_rest_quintic_segments():
    """The printed tables are not the via rates (deg/s) but means of the peak rates of jtraj segments [rad]."""
    segments = [jtraj(np.deg2rad(XIANG_POSITIONS_DEG[:, k]), np.deg2rad(XIANG_POSITIONS_DEG[:, k + 1]),
                      np.arange(0.0, 10.5, 1.0)) for k in range(3)]  # sampled every second, as a 1 s grid
    peak_velocity = np.array([s.qd[np.abs(s.qd).argmax(axis=0), range(4)] for s in segments]).T  # (4, 3)
    peak_acceleration = np.array([np.abs(s.qdd).max(axis=0) for s in segments]).T
    velocity = 0.5 * (peak_velocity[:, :-1] + peak_velocity[:, 1:])
    acceleration = 0.5 * (peak_acceleration[:, :-1] + peak_acceleration[:, 1:])
    assert np.abs(velocity - XIANG_VELOCITY_TABLE).max() <= 0.0005  # all 8 entries to the printed digits
    # 15/8 is the quintic's peak-to-mean speed ratio: the same numbers as 15/8 x the averaged slopes in rad/s.
    averaged = np.rad2deg(xiang_trajectory(3).velocities[1:3].T)
    assert np.allclose(velocity, np.deg2rad(averaged) * 15 / 8, atol=1e-12)
    # Accelerations: magnitudes match 7 of 8 entries (joint 2 at via 2 prints |25 - 5| instead of 25 + 5).
    matches = np.abs(acceleration - np.abs(XIANG_ACCELERATION_TABLE)) <= 0.00003
    assert matches.sum() == 7 and not matches[1, 0]


def test_jtraj_boundaries_exact_and_time_forms():
    q0, q1 = np.array([0.1, -0.4, 2.0]), np.array([1.2, 0.3, -1.0])
    timed = jtraj(q0, q1, np.linspace(2.0, 5.0, 31))
    assert np.abs(timed.q[0] - q0).max() == 0.0 and np.abs(timed.q[-1] - q1).max() < 1e-14
    assert np.abs(timed.qd[[0, -1]]).max() < 1e-14 and np.abs(timed.qdd[[0, -1]]).max() < 1e-13
    assert timed.t[0] == 0.0 and timed.t[-1] == pytest.approx(3.0)
    assert np.allclose(timed.qd[15], 15 / 8 * (q1 - q0) / 3.0)  # peak speed of the quintic at mid-time
    normalized = jtraj(q0, q1, 31)
    assert np.allclose(normalized.q, timed.q) and np.allclose(normalized.qd, 3.0 * timed.qd)
    moving = jtraj(q0, q1, 11, qd0=[1.0, 0.0, 0.0], qd1=[0.0, 2.0, 0.0])
    assert moving.qd[0] == pytest.approx([1.0, 0, 0]) and moving.qd[-1] == pytest.approx([0, 2.0, 0])


def test_ctraj_is_a_straight_line_with_slerp():
    start, end = pin.SE3(np.eye(3), np.zeros(3)), pin.SE3(pin.rpy.rpyToMatrix(0.3, -0.2, 1.0),
                                                          np.array([1.0, 2.0, -0.5]))
    samples = ctraj(start, end, 21)
    assert samples.matrices.shape == (21, 4, 4)
    assert np.allclose(samples.poses[0].homogeneous, start.homogeneous)
    assert np.allclose(samples.poses[-1].homogeneous, end.homogeneous)
    points = np.array([pose.translation for pose in samples.poses])
    assert np.allclose(np.cross(points, end.translation), 0.0, atol=1e-14)  # on the line through the origin
    axis = pin.log3(end.rotation)
    for pose in samples.poses:  # every rotation on the geodesic: same axis, growing angle
        assert np.allclose(np.cross(pin.log3(pose.rotation), axis), 0.0, atol=1e-12)
    assert np.abs(samples.twist[[0, -1]]).max() < 1e-14


@pytest.mark.parametrize("arguments, message", [
    (dict(points=[[0.0], [1.0]], times=[0.0, 0.0]), "strictly increasing"),
    (dict(points=[[0.0], [1.0]], times=[0.0, 1.0, 2.0]), "one per via point"),
    (dict(points=[[0.0], [np.nan]], times=[0.0, 1.0]), "finite"),
    (dict(points=[[0.0], [1.0]], times=[0.0, 1.0], degree=4), "degree"),
    (dict(points=[[0.0], [1.0]], times=[0.0, 1.0], velocities=[[0.0, 1.0]]), "shape"),
])
def test_via_point_errors(arguments, message):
    with pytest.raises(UVMSError, match=message):
        ViaPointTrajectory(**arguments)


def test_a_path_trajectory_at_many_times_is_its_samples_one_by_one_bit_for_bit():
    """``at`` over 1,001 times (numpy's vector loops) against one call per time, for a circle, a line and a hold."""
    from uvms.trajectory import PointPath, hold

    times = np.linspace(-1.0, 200.0, 1001)
    circle = PathTrajectory(CirclePath([0.0, 2.0, 0.0], [0.0, -2.0, 0.0]), LAWS[0], orientation=[0.0, 0.0, 1.0])
    line = PathTrajectory(LinePath([0.1, 0.2, 0.3], [1.0, -1.0, 2.0]), LAWS[3], orientation=[0.2, 0.0, 0.0])
    held = hold(pin.SE3(pin.rpy.rpyToMatrix(0.1, 0.2, 0.3), np.array([1.0, 2.0, 3.0])), 5.0)
    for trajectory in (circle, line, held):
        table = trajectory.at(times)
        assert len(table) == len(times)
        for index in (0, 1, 137, 500, 999, 1000):
            one, row = trajectory(times[index]), table.sample(index)
            assert np.array_equal(one.pose.homogeneous, row.pose.homogeneous)
            assert np.array_equal(one.twist, row.twist) and np.array_equal(one.acceleration, row.acceleration)
        with pytest.raises(ValueError, match="read-only"):
            table.twists[0, 0] = 1.0  # a sample's arrays are views of the table's
    assert np.array_equal(held.at(times).translations, np.tile([1.0, 2.0, 3.0], (len(times), 1)))
    assert np.array_equal(PointPath([1.0, 2.0, 3.0])(7.0).tangent, np.zeros(3))


def test_a_trajectory_table_gives_the_trajectorys_samples_and_evaluates_other_times_when_asked():
    from uvms.trajectory import TrajectoryTable

    circle = PathTrajectory(CirclePath([0.0, 2.0, 0.0], [0.0, -2.0, 0.0]), LAWS[0], orientation=[0.0, 0.0, 1.0])
    se3 = SE3Trajectory([0.0, 0.0, 0.0, 0.0, 0.0, 0.0], [1.0, 2.0, 0.5, 0.3, -0.2, 1.0], LAWS[2])  # without `at`
    times = [k * 0.02 for k in range(200)]
    for trajectory in (circle, se3):
        table = TrajectoryTable(trajectory, times + times[:5])  # repeated times: one row each
        assert table.duration == trajectory.duration
        for t in (times[0], times[77], 0.0123, 500.0):  # two in the table, two outside it
            sample, expected = table(t), trajectory(t)
            assert np.array_equal(sample.pose.homogeneous, expected.pose.homogeneous)
            assert np.array_equal(sample.twist, expected.twist)


def test_twists_at_many_times_are_the_trajectorys_one_by_one():
    """``twists_at`` (a run's desired speed, drawn) gives each time's twist bit for bit, through ``at`` where the
    trajectory has it and one call per time where it does not; an empty time list gives (0, 6)."""
    from uvms.trajectory.table import twists_at

    circle = PathTrajectory(CirclePath([0.0, 2.0, 0.0], [0.0, -2.0, 0.0]), LAWS[0], orientation=[0.0, 0.0, 1.0])
    se3 = SE3Trajectory([0.0, 0.0, 0.0, 0.0, 0.0, 0.0], [1.0, 2.0, 0.5, 0.3, -0.2, 1.0], LAWS[2])  # without `at`
    times = np.array([k * 0.02 for k in range(9501)])
    for trajectory in (circle, se3):
        twists = twists_at(trajectory, times)
        assert twists.shape == (len(times), 6)
        for index in (0, 1, 250, 4750, 9500):
            assert np.array_equal(twists[index], trajectory(times[index]).twist)
        assert twists_at(trajectory, np.zeros(0)).shape == (0, 6)
    speed = np.linalg.norm(twists_at(circle, times)[:, :3], axis=1)
    assert speed.max() == pytest.approx(0.5, rel=1e-12) and speed[0] == 0.0  # hoang2011's 0.5 m/s, from rest


def test_a_trajectory_tables_targets_are_its_samples_arrays_with_their_rpy_in_a_poses_layout():
    from uvms.trajectory import RecentSamples, TrajectoryTable

    circle = PathTrajectory(CirclePath([0.0, 2.0, 0.0], [0.0, -2.0, 0.0]), LAWS[0], orientation=[0.3, -0.2, 1.0])
    se3 = SE3Trajectory([0.0, 0.0, 0.0, 0.0, 0.0, 0.0], [1.0, 2.0, 0.5, 0.3, -0.2, 1.0], LAWS[2])  # without `at`
    times = [k * 0.02 for k in range(200)]
    samples = circle.at(np.array(times))
    assert np.array_equal(samples.rpy, np.tile(pin.rpy.matrixToRpy(circle.rotation), (200, 1)))
    for trajectory in (circle, se3):
        table = TrajectoryTable(trajectory, times)
        for t in (times[0], times[77], 0.0123):  # two in the table (of the circle), one outside it
            expected = trajectory(t)
            for source, tabled in ((table, True), (RecentSamples(table), True), (RecentSamples(trajectory), False)):
                translation, rotation, twist, rpy = source.target(t)
                assert np.array_equal(translation, expected.pose.translation)
                assert np.array_equal(rotation, expected.pose.rotation)
                assert np.array_equal(twist, expected.twist)
                if not (tabled and trajectory is circle and t != 0.0123):
                    assert rpy is None  # the task computes it
                    continue
                assert np.array_equal(rpy, pin.rpy.matrixToRpy(expected.pose.rotation))
                # a pose's layout (what a compiled step was built for), writeable: a row of the table's own arrays
                assert rotation.flags.f_contiguous and translation.flags.c_contiguous and twist.flags.writeable
                assert not np.shares_memory(translation, samples.translations)


def test_a_pose_function_gives_the_trajectorys_poses_bit_for_bit():
    """``pose_function`` (a run's desired pose, for its task series) is ``trajectory(t).pose``, from a table's target
    arrays where the source has them, at tabled and untabled times, and of a trajectory without ``target``."""
    from uvms.trajectory import RecentSamples, TrajectoryTable
    from uvms.trajectory.table import pose_function

    circle = PathTrajectory(CirclePath([0.0, 2.0, 0.0], [0.0, -2.0, 0.0]), LAWS[0], orientation=[0.3, -0.2, 1.0])
    se3 = SE3Trajectory([0.0, 0.0, 0.0, 0.0, 0.0, 0.0], [1.0, 2.0, 0.5, 0.3, -0.2, 1.0], LAWS[2])  # without `at`
    times = [k * 0.02 for k in range(200)]
    for trajectory in (circle, se3):
        table = TrajectoryTable(trajectory, times)
        for source in (trajectory, table, RecentSamples(table)):
            pose = pose_function(source)
            for t in (times[0], times[77], times[-1], 0.0123):
                assert np.array_equal(pose(t).homogeneous, trajectory(t).pose.homogeneous)
    tabled = pose_function(TrajectoryTable(circle, times))(times[5])
    tabled.translation = np.zeros(3)  # a pose of its own: the table's row is not written
    assert np.array_equal(pose_function(TrajectoryTable(circle, times))(times[5]).translation,
                          circle(times[5]).pose.translation)
