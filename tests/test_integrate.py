"""Integration (uvms.numerics.integrate): the RK4 stages' square solve, and the trajectory samples an RK4 step reuses."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import uvms
from uvms.errors import NumericalError
from uvms.numerics.integrate import rk4_step, solve_square
from uvms.trajectory import CirclePath, PathTrajectory, RecentSamples, TrapezoidLaw


def test_the_square_solve_of_the_rk4_stages_is_numpy_solve_and_refuses_a_singular_system(rng):
    for size in (3, 6, 12):
        matrix, rhs = rng.normal(size=(size, size)) + 3 * np.eye(size), rng.normal(size=size)
        assert np.array_equal(solve_square(matrix, rhs), np.linalg.solve(matrix, rhs))
    with pytest.raises(NumericalError, match="singular 2x2"):
        solve_square(np.ones((2, 2)), np.ones(2))


def misses(dt: float, steps: int) -> int:
    """Steps whose first time k dt is not bit for bit the last stage's (k - 1) dt + dt of the step before."""
    return sum((k - 1) * dt + dt != k * dt for k in range(1, steps))


def test_recent_samples_evaluate_the_trajectory_twice_per_rk4_step():
    law = TrapezoidLaw(speed=0.5, duration=4.0, accel_time=1.0)
    trajectory = PathTrajectory(CirclePath([0.0, 2.0, 0.0], [0.0, -2.0, 0.0]), law)
    times: list[float] = []

    def counted(t: float):
        times.append(t)
        return trajectory(t)

    recent = RecentSamples(counted)
    robot = uvms.load("hoang2011")
    model, dt = robot.model, 0.02
    q = robot.neutral()

    def rate(t, q, x):
        sample = recent(t)
        assert sample is recent(t)  # the same object for the same t, while it is kept
        return np.r_[sample.twist[:2], 0.0, np.zeros(robot.nv - 3)], x

    for k in range(50):
        t = k * dt
        q, _ = rk4_step(model, rate, t, q, np.zeros(0), dt, rate(t, q, np.zeros(0)))
    # t, t + dt/2 (the second and third stages), t + dt: the last is the next step's first when k dt rounds alike
    assert len(set(times)) == len(times) == 2 * 50 + 1 + misses(dt, 50)
    sample = recent(0.5)
    assert np.array_equal(sample.pose.translation, trajectory(0.5).pose.translation)
    assert np.array_equal(sample.twist, trajectory(0.5).twist)
    assert isinstance(sample.pose, pin.SE3)
