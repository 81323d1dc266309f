"""ActuatedPlant.of (uvms.dynamics.plant.actuated): a plant with its model's thrusters and fins."""

from __future__ import annotations

import types
from pathlib import Path

import numpy as np
import pytest

import uvms
from uvms.control import OpenLoop
from uvms.dynamics.hydro.hydrodynamics import hydrodynamics_of
from uvms.dynamics.plant.actuated import ActuatedPlant
from uvms.dynamics.plant.command import Command
from uvms.dynamics.plant.plant import Plant
from uvms.dynamics.thrusters.fins import fins_of
from uvms.dynamics.thrusters.thrusters import allocation_matrix, thrusters_of
from uvms.errors import BaseGuessWarning, PointMassWarning, UVMSError

from conftest import body_urdf, shipped

TORPEDO = Path(__file__).parents[2] / "fixtures" / "auv" / "torpedo.urdf"


def test_of_puts_the_models_thrusters_on_the_plant_at_rest():
    blue = shipped("bluerov2_alpha5")
    plant = Plant(blue)
    actuated = ActuatedPlant.of(plant)
    thrusters = thrusters_of(blue)
    assert actuated.plant is plant and actuated.thrusters.names == thrusters.names and actuated.n == 8
    np.testing.assert_allclose(actuated.matrix, allocation_matrix(blue, thrusters), atol=1e-15)
    np.testing.assert_array_equal(actuated.thrusts0, np.zeros(8))
    assert actuated.m == 0 and ActuatedPlant.of(plant, fins=False).m == 0  # the BlueROV2 has no fins


def test_of_refuses_a_model_without_thrusters():
    with pytest.raises(UVMSError, match="no thrusters"):
        ActuatedPlant.of(Plant(uvms.load(body_urdf())))


def test_of_gives_the_fins_when_asked():
    with pytest.warns(PointMassWarning), pytest.warns(BaseGuessWarning):
        torpedo = uvms.load(TORPEDO)
    plant = Plant(torpedo, hydrodynamics_of(torpedo))
    assert ActuatedPlant.of(plant).fins.names == fins_of(torpedo).names and ActuatedPlant.of(plant).m == 4
    assert ActuatedPlant.of(plant, fins=False).m == 0 and ActuatedPlant.of(plant, fins=False).n == 1


def torpedo_or_bluerov(fins: bool) -> ActuatedPlant:
    """The torpedo AUV's actuated plant with its four fins, or the BlueROV2 + Alpha 5's (thrusters only)."""
    if fins:
        with pytest.warns(PointMassWarning), pytest.warns(BaseGuessWarning):
            robot = uvms.load(TORPEDO)
        return ActuatedPlant.of(Plant(robot, hydrodynamics_of(robot)))
    return ActuatedPlant.of(Plant(shipped("bluerov2_alpha5")))


@pytest.mark.parametrize("fins", [False, True])
def test_the_state_rate_is_written_in_place_with_the_numbers_of_its_parts(fins, rng):
    """The actuated rate [v', f', delta'] (written part by part into one array) and the sample's wrench are those of
    the plant's dynamics, the thrusters' lag and the fins' computed on their own, bit for bit; an integrator's stage
    (no motor torques) gives the same rate."""
    actuated = torpedo_or_bluerov(fins)
    plant, system = actuated.plant, actuated.system(None, dt=0.01)
    assert (actuated.m > 0) == fins
    q = plant.robot.neutral()
    x = np.concatenate([rng.normal(size=plant.model.nv), rng.uniform(actuated.lower, actuated.upper),
                        0.1 * rng.normal(size=actuated.m)])
    v, thrusts, angles = system._split(x)
    arm, command = rng.normal(size=plant.n_arm), rng.uniform(actuated.lower, actuated.upper)
    fin_command = 0.1 * rng.normal(size=actuated.m)
    dynamics, (velocity, rate), wrench = system._rate(q, x, arm, command, fin_command)
    expected_wrench = actuated.matrix @ thrusts + (actuated.fin_wrench(q, v, angles) if fins else 0.0)
    expected = plant.dynamics(q, v, arm, actuated.matrix @ thrusts + actuated.fin_wrench(q, v, angles) if fins
                              else actuated.matrix @ thrusts)
    np.testing.assert_array_equal(wrench, expected_wrench)
    lag = (command - thrusts) / actuated.time_constants
    np.testing.assert_array_equal(rate, np.concatenate([expected.acceleration, lag,
                                                        actuated.fins.rate(angles, fin_command)]))
    np.testing.assert_array_equal(dynamics.joint_torque, expected.joint_torque)
    assert velocity is not None and np.shares_memory(dynamics.acceleration, rate)  # v' is the rate's first part
    # an integrator's stage: the same rate without the motor torques (Plant.stage_acceleration)
    none, (_, stage), stage_wrench = system._rate(q, x, arm, command, fin_command, False)
    assert none is None
    np.testing.assert_array_equal(stage, rate)
    np.testing.assert_array_equal(stage_wrench, wrench)
    np.testing.assert_array_equal(plant.stage_acceleration(q, v, arm, wrench), expected.acceleration)
    np.testing.assert_array_equal(plant.stage_acceleration(q, v, arm), plant.dynamics(q, v, arm).acceleration)
    # the stage the integrator calls (the plant's prepared stage without fins): the same (v, rate), new arrays
    held = types.SimpleNamespace(command=Command(arm=arm), thrust_command=command, fin_command=fin_command)
    stage_rate = system.stage_rate(held)
    velocity_stage, rate_stage = stage_rate(0.0, q, x)
    np.testing.assert_array_equal(velocity_stage, v)
    np.testing.assert_array_equal(rate_stage, rate)
    assert rate_stage is not stage_rate(0.0, q, x)[1]  # a stage's rate is its own: RK4 keeps all four


def test_a_state_is_refused_only_when_an_entry_is_not_finite():
    """check_finite_state: a state of finite entries is kept (however large), a NaN or an infinity anywhere is
    refused."""
    from uvms.dynamics.plant.system import check_finite_state

    q, x = np.array([1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]), np.zeros(14)
    check_finite_state(0.1, q, x, 0.01)
    check_finite_state(0.1, q, np.full(14, 1e300), 0.01)  # every entry finite
    check_finite_state(0.1, q, np.zeros(0), 0.01)  # no vector part
    for bad in (np.nan, np.inf, -np.inf):
        for where in ("q", "x"):
            q_bad, x_bad = q.copy(), x.copy()
            (q_bad if where == "q" else x_bad)[3] = bad
            with pytest.raises(UVMSError, match=r"non-finite at t = 0\.1 s; reduce dt \(now 0\.01 s\)"):
                check_finite_state(0.1, q_bad, x_bad, 0.01)


@pytest.mark.parametrize("fins", [False, True])
def test_a_command_that_is_not_finite_is_refused_with_or_without_fins(fins):
    """The controller's arm rates, thrusts and fin angles are checked before the plant applies them (the fins' only
    where the vehicle has fins): a NaN anywhere is refused, naming what was expected."""
    actuated = torpedo_or_bluerov(fins)
    plant, n, m = actuated.plant, actuated.n, actuated.m
    q0 = plant.robot.neutral()
    good = {"arm": np.zeros(plant.n_arm), "thrust": np.ones(n), "fins": np.zeros(m) if m else None}
    system = actuated.system(OpenLoop(**good), dt=0.01)
    q, x = system.initial_state(q0, None)
    assert np.isfinite(system.sample(0.0, q, x).rate[1]).all()
    bad = [("thrust", np.full(n, np.nan))] + ([("fins", np.full(m, np.nan))] if m else [])
    for name, value in bad:
        system = actuated.system(OpenLoop(**{**good, name: value}), dt=0.01)
        q, x = system.initial_state(q0, None)
        with pytest.raises(UVMSError, match=f"{n} finite thrusts"):
            system.sample(0.0, q, x)
