"""Integration (uvms.numerics.integrate): the RK4 stages' square solve, the trajectory samples an RK4 step reuses,
and one step per scheme for q alone and for (q, v), exact on the manifold."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from scipy.linalg import lapack

import uvms
from uvms.errors import NumericalError
from uvms.numerics.integrate import INTEGRATORS, STEPS, check_integrator, check_tangent_solve, rk4_step, stage_times
from uvms.trajectory import CirclePath, PathTrajectory, RecentSamples, TrapezoidLaw

from conftest import FIXED_ARM


def scipy_solve(matrix: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """x with A x = b by scipy.linalg.lapack.dgesv: the stages' tangent solve before it was compiled (its numbers)."""
    _, _, solution, info = lapack.dgesv(matrix, rhs)
    assert info == 0
    return solution


def test_a_singular_stage_tangent_is_refused():
    with pytest.raises(NumericalError, match=r"singular 2x2 system \(LAPACK dgesv info 2\)"):
        check_tangent_solve(2, 2)
    check_tangent_solve(0, 2)


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


@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_stage_times_are_every_time_a_run_asks_its_controller_for(integrator):
    """The times of a kinematic run's controller calls (rows and stages), bit for bit, over steps where k dt and
    (k - 1) dt + dt round apart (dt = 0.1)."""
    robot = uvms.load("hoang2011")
    asked: list[float] = []

    class Recorded(uvms.control.OpenLoop):
        def command(self, state, t):
            asked.append(t)
            return super().command(state, t)

    controller = Recorded(velocity=np.full(robot.nv, 0.01), info=uvms.solvers.SolverResult(np.zeros(robot.nv), 1.0,
                                                                                            0.0))

    steps, dt = 40, 0.1
    assert misses(dt, steps) > 0
    uvms.simulate(robot, controller, robot.neutral(), steps * dt, dt, integrator=integrator, progress=False)
    times = stage_times(steps, dt, integrator)
    assert set(asked) == set(times) and len(times) == (steps + 1 if integrator == "euler" else 3 * steps + 1)


# ------------------------------------------------------------ one step per scheme, for q alone and for (q, v)
def test_one_step_per_scheme_serves_q_alone_and_q_with_x_exactly_on_the_manifold():
    """A rigid body spinning about a fixed axis: q alone (kinematic), then (q, v) with v' = 0 (dynamic)."""
    model = uvms.load(FIXED_ARM, base="floating").model  # a free vehicle (nq = 7 + 1): spin it, arm at rest
    twist = np.concatenate([[0.2, -0.1, 0.3, 0.5, -0.4, 0.7], [0.0]])
    exact = pin.integrate(model, pin.neutral(model), twist * 1.0)
    empty = np.zeros(0)
    for name in INTEGRATORS:
        errors = []
        for steps in (10, 20):
            dt, q, v = 1.0 / steps, pin.neutral(model), twist.copy()
            for k in range(steps):
                q, v = STEPS[name](model, lambda t, qq, vv: (vv, np.zeros(7)), k * dt, q, v, dt, (v, np.zeros(7)))
            q_alone = pin.neutral(model)
            for k in range(steps):
                q_alone, _ = STEPS[name](model, lambda t, qq, x: (twist, empty), k * dt, q_alone, empty, dt,
                                         (twist, empty))
            assert np.array_equal(q, q_alone)
            errors.append(np.linalg.norm(pin.difference(model, q, exact)))
        assert errors[1] <= 1e-12  # a constant body twist is the exponential map: exact for both
    with pytest.raises(uvms.UVMSError, match="unknown method 'rk45'; valid: euler, rk4"):
        check_integrator("rk45", "method")


def test_numpy_solve_is_numpy_linalg_solve_and_refuses_a_singular_system():
    """The plant's base solve: numpy's numbers bit for bit (the shipped runs stay bit-identical), a singular
    system a NumericalError instead of NaN accelerations."""
    from uvms.numerics.lapack import numpy_solve

    rng = np.random.default_rng(3)
    matrix, rhs = rng.normal(size=(6, 6)) + 6.0 * np.eye(6), rng.normal(size=6)
    np.testing.assert_array_equal(numpy_solve(matrix, rhs), np.linalg.solve(matrix, rhs))
    with np.errstate(invalid="ignore"), pytest.raises(NumericalError, match="singular"):
        numpy_solve(np.zeros((6, 6)), rhs)


def test_the_compiled_rk4_arithmetic_gives_numpys_numbers_bit_for_bit(rng):
    """The stages' arguments, their tangent solves and the weighted sums are compiled
    (uvms.numerics._kernels.runge_kutta, SciPy's dgesv inside): the step equals the same step written as numpy
    expressions and SciPy's dgesv, bit for bit, with a vector state and with none (a kinematic run), and passes each
    stage its own arrays."""
    robot = uvms.load("bluerov2_alpha5")
    model = robot.model
    matrix = rng.normal(size=(19, 11 + 19))  # a rate that mixes q and x nonlinearly

    def rate(t, q, x):
        z = np.tanh(matrix @ np.concatenate([pin.difference(model, robot.neutral(), q), x]) + t)
        return z[:11] * 3.0, z * 7.0

    def numpy_step(q, x, dt, first, rate=rate):  # the step as numpy expressions (rk4_step before its kernels)
        half = 0.5 * dt

        def stage(xi, x_stage, time_):
            velocity, x_rate = rate(time_, pin.integrate(model, q, xi), x_stage)
            return scipy_solve(pin.dIntegrate(model, q, xi, pin.ArgumentPosition.ARG1), velocity), x_rate

        k1q, k1x = first
        k2q, k2x = stage(half * k1q, x + half * k1x, half)
        k3q, k3x = stage(half * k2q, x + half * k2x, half)
        k4q, k4x = stage(dt * k3q, x + dt * k3x, dt)
        return (pin.integrate(model, q, dt / 6.0 * (k1q + 2.0 * k2q + 2.0 * k3q + k4q)),
                x + dt / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x))

    seen = []
    for _ in range(3):
        q = pin.integrate(model, robot.neutral(), rng.normal(size=11))
        x, dt = rng.normal(size=19), rng.uniform(0.001, 0.05)
        first = rate(0.0, q, x)
        expected = numpy_step(q, x, dt, first)
        got = rk4_step(model, lambda t, q_, x_: (seen.append(x_), rate(t, q_, x_))[1], 0.0, q, x, dt, first)
        np.testing.assert_array_equal(got[0], expected[0])
        np.testing.assert_array_equal(got[1], expected[1])
        assert not np.array_equal(got[1], x)
    assert len({id(x_) for x_ in seen}) == len(seen) == 9  # a new array at every stage

    def kinematic(t, q, x):  # a kinematic run's rate: q's velocity alone, an empty vector part
        return rate(t, q, np.zeros(19))[0], np.zeros(0)

    for _ in range(3):  # the same kernels with an empty x: the numbers of the numpy step
        q, dt = pin.integrate(model, robot.neutral(), rng.normal(size=11)), rng.uniform(0.001, 0.05)
        first = kinematic(0.0, q, np.zeros(0))
        expected = numpy_step(q, np.zeros(0), dt, first, kinematic)
        got = rk4_step(model, kinematic, 0.0, q, np.zeros(0), dt, first)
        assert got[0].tobytes() == expected[0].tobytes() and got[1].shape == (0,)
