"""The actuated chain's vehicle side per step (uvms.control.coordination, uvms.control.vehicle; the error series of
uvms.control.station): what it keeps or reads instead of computing again gives what computing again gives."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from uvms.control.coordination import FULL_RATIO
from uvms.dynamics.plant.command import State
from uvms.scenario.build import build
from uvms.scenario.schema import read_scenario

SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "bluerov2_alpha5_intervention.toml"


@pytest.fixture(scope="module")
def setup():
    return build(read_scenario(SCENARIO, ["outputs.figures=false"]))


def states(setup, count: int, seed: int = 5) -> list[State]:
    """Measured states about the start: q (nq,) near q0, v (nv,) small, the thrusters at rest."""
    rng = np.random.default_rng(seed)
    nv = setup.robot.nv
    return [State(pin.integrate(setup.robot.model, setup.q0, 0.02 * rng.normal(size=nv)), 0.05 * rng.normal(size=nv),
                  np.zeros(8), np.zeros(0)) for _ in range(count)]


def test_the_error_series_are_the_stations_and_the_trajectorys_errors_at_each_stored_row(setup):
    """The chain's errors, derived after the loop from the stored rows (t, q), against Pinocchio's poses computed
    apart: the base frame's distance and log3 angle from the station, the end effector's position and distance
    from the trajectory's point; the solver's own configuration is left where its last step put it."""
    controller = setup.actuation.controller
    kinematic, robot = controller.kinematic, setup.robot
    measured = states(setup, 5, seed=3)
    controller.reset(measured[0], 0.0)
    kinematic.reference(0.5, measured[0].q)
    kept = kinematic._configuration.q
    t = np.array([0.0, 0.5, 1.25, 2.0, 3.0])
    q = np.array([state.q for state in measured])
    series = controller.derived_series(t, q)
    assert kinematic._configuration.q is kept
    station, frame = kinematic.vehicle_target, robot.model.frames[kinematic.task.frame_id].name
    for row in range(len(t)):
        base = robot.base_pose(q[row]) * robot.base_placement
        ee = robot.fk(q[row], frame).translation
        point = kinematic.task_reference.samples.target(float(t[row]))[0]
        assert series["vehicle_position_error"][row] == pytest.approx(
            np.linalg.norm(station.translation - base.translation), abs=1e-12)
        assert series["vehicle_attitude_error"][row] == pytest.approx(
            np.linalg.norm(pin.log3(base.rotation.T @ station.rotation)), abs=1e-12)
        np.testing.assert_allclose(series["ee_position"][row], ee, rtol=0.0, atol=1e-12)
        assert series["ee_point_error"][row] == pytest.approx(np.linalg.norm(point - ee), abs=1e-12)
    assert series["vehicle_position_error"][0] == 0.0  # the station: the first state's base frame
    assert series["vehicle_position_error"][1:].min() > 1e-3 and series["ee_point_error"].min() > 1e-3


KEPT = ("velocity_integral", "disturbance_estimate", "wrench_command", "achieved_wrench", "nu_ref")


def test_each_rows_arrays_keep_their_numbers_after_later_steps(setup):
    """The rows and commands hold the loops' arrays without a copy (the integral, the estimate, the wrenches, nu_ref,
    the arm's and thrusters' commands): the compiled calls write later steps into new arrays, never into a kept one
    (the buffers they reuse are read within a step only), so a row's numbers are those of its step."""
    controller = setup.actuation.controller
    measured = states(setup, 4, seed=9)
    controller.reset(measured[0], 0.0)
    rows, snapshots = [], []
    for step, state in enumerate(measured):
        command = controller.command(state, 0.5 + 0.01 * step)
        kept = {**{name: command.info[name] for name in KEPT}, "arm": command.arm, "thrust": command.thrust}
        rows.append(kept)
        snapshots.append({name: value.copy() for name, value in kept.items()})
    for name in snapshots[0]:
        assert not np.array_equal(snapshots[1][name], snapshots[-1][name]), name  # each moved between the steps
    for kept, snapshot in zip(rows, snapshots):
        for name, value in snapshot.items():
            assert np.array_equal(kept[name], value), name


def test_the_full_ratio_is_shared_read_only(setup):
    controller = setup.actuation.controller
    controller.reset(states(setup, 1)[0], 0.0)
    assert controller.ratio is FULL_RATIO and np.array_equal(FULL_RATIO, np.ones(6))
    with pytest.raises(ValueError, match="read-only"):
        controller.ratio[0] = 0.5


def test_the_observer_gain_follows_its_step_and_time_constant(setup):
    velocity = setup.actuation.controller.velocity
    original = velocity.disturbance_time_constant
    try:
        for time_constant, dt in ((0.1, 0.01), (0.1, 0.01), (0.1, 0.02), (0.3, 0.02), (0.3, 0.01)):
            velocity.disturbance_time_constant = time_constant
            gain = velocity._observer_gain(dt)
            assert gain == -np.expm1(-dt / time_constant) and type(gain) is np.float64
    finally:
        velocity.disturbance_time_constant = original


def test_the_compiled_loops_refuse_what_they_cannot_read(setup):
    """The loops' compiled calls read fixed sizes: a reference, wrench or velocity of another size, or gains not
    derived yet, are refused with what is valid (never read past an array's end)."""
    from uvms.control.settings import ActuatedSettings
    from uvms.control.vehicle import VehicleVelocityController
    from uvms.errors import SolverInputError

    velocity = setup.actuation.controller.velocity
    state = states(setup, 1)[0]
    q, v = state.q, state.v
    velocity.reset(q)
    with pytest.raises(SolverInputError, match="nu_ref as 6 numbers"):
        velocity.control(q, v, np.zeros(3), 0.01)
    velocity.observe(q, v, np.zeros(6), 0.01)
    with pytest.raises(SolverInputError, match="applied wrench as 6 numbers"):
        velocity.observe(q, v, np.zeros(3), 0.01)
    with pytest.raises(SolverInputError, match="v of the last call's size"):
        velocity.observe(q, v[:8], np.zeros(6), 0.01)
    underived = VehicleVelocityController(velocity.model, velocity.allocator, ActuatedSettings())
    with pytest.raises(SolverInputError, match="derived at the station"):
        underived.control(q, v, np.zeros(6), 0.01)
    underived.reset(q)
    assert underived.control(q, v, np.zeros(6), 0.01).wrench.shape == (6,)


def test_the_feedforward_from_the_observers_terms_is_the_one_evaluated_alone(setup):
    """The model's terms observe returns (evaluated with the observer's, at the same q) give the feedforward and the
    control output the model evaluated at control time gives, bit for bit, with and without the arm's motion fed
    forward; the first call evaluates nothing (None)."""
    velocity = setup.actuation.controller.velocity
    measured = states(setup, 4, seed=11)
    rng = np.random.default_rng(4)
    original = velocity.arm_feedforward
    try:
        for arm_feedforward in (True, False):
            velocity.arm_feedforward = arm_feedforward
            velocity.reset(measured[0].q)
            assert velocity.observe(measured[0].q, measured[0].v, np.zeros(6), 0.01) is None
            for state in measured[1:]:
                terms = velocity.observe(state.q, state.v, rng.normal(size=6), 0.01)
                rate, arm = rng.normal(size=6), rng.normal(size=setup.robot.n_arm)
                alone = velocity.feedforward(state.q, state.v, rate, arm)
                assert np.array_equal(velocity.feedforward(state.q, state.v, rate, arm, terms), alone)
                reference, kept = 0.1 * rng.normal(size=6), (velocity.integral, velocity._short, velocity._falls_short)
                outputs = []
                for given in (None, terms):  # the same step twice, the loop's state as it was before it
                    velocity.integral, velocity._short, velocity._falls_short = kept
                    control = velocity.control(state.q, state.v, reference, 0.01, reference_rate=rate,
                                               arm_acceleration=arm, terms=given)
                    outputs.append((control.feedforward, control.wrench, control.allocation.thrusts, velocity.integral))
                for evaluated, read in zip(*outputs):
                    assert np.array_equal(evaluated, read)
    finally:
        velocity.arm_feedforward = original
