"""The actuated chain's vehicle side per step (uvms.control.coordination, uvms.control.vehicle, the errors of
uvms.control.station): what it keeps or reads instead of computing again gives what computing again gives."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from uvms.control.coordination import FULL_RATIO
from uvms.dynamics.plant.command import State
from uvms.robot.configuration import Configuration
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


def test_the_errors_read_the_steps_kinematics_at_its_q_and_compute_them_at_another(setup, monkeypatch):
    controller = setup.actuation.controller
    kinematic = controller.kinematic
    first, second = states(setup, 2)
    controller.reset(first, 0.0)
    kinematic.reference(0.5, first.q)
    updates = []
    original = Configuration.update
    monkeypatch.setattr(Configuration, "update", lambda self, q, **k: (updates.append(q), original(self, q, **k)))
    kept = kinematic.errors(0.5, first.q)
    assert updates == []  # the reference's kinematics, not computed again
    fresh = build(read_scenario(SCENARIO, ["outputs.figures=false"])).actuation.controller
    fresh.reset(first, 0.0)
    for q in (first.q.copy(), second.q):  # another array (the same numbers, then others): computed there
        row = kinematic.errors(0.5, q)
        assert updates[-1] is q
        expected = fresh.kinematic.errors(0.5, q)  # computed at q: its configuration was never at this array
        assert row.keys() == expected.keys()
        for name in row:
            assert np.array_equal(row[name], expected[name]), name
    for name in kept:  # the kept kinematics gave the numbers computing them again gives
        assert np.array_equal(kept[name], kinematic.errors(0.5, first.q.copy())[name]), name


KEPT = ("velocity_integral", "disturbance_estimate", "wrench_command", "achieved_wrench", "nu_ref", "ee_position")


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
