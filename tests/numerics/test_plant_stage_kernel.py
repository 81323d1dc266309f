"""The plant's equations of motion around its hydrodynamic pass in one compiled call
(uvms.numerics._kernels.plant_stage): the body wrench's generalized force, the motors' accelerations, the vehicle's
solve, the motor torques and the thrusters' wrench and lag give the numbers of the numpy expressions they replace, bit
for bit (the reference below is that numpy code, with ``pin.getFrameJacobian``)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import uvms
from uvms.dynamics.plant.actuated import ActuatedPlant
from uvms.dynamics.plant.plant import Plant

from conftest import FLOATING_ROOT, body_urdf, shipped, urdf


def numpy_dynamics(plant: Plant, q: np.ndarray, v: np.ndarray, command: np.ndarray,
                   wrench: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(v', tau_m, Mbar, nbar) as the plant computed them with numpy: the wrench through getFrameJacobian, the
    motors' and the vehicle's accelerations, the torques, each expression in its order."""
    mass, bias = plant._mass_and_bias(q, v)  # the hydrodynamic pass alone (no wrench)
    if wrench is not None:
        data = plant.model.createData()
        pin.computeJointJacobians(plant.model, data, q)
        bias -= wrench @ pin.getFrameJacobian(plant.model, data, plant.base_frame, pin.LOCAL)
    nb = plant.nb
    acceleration = np.empty(len(v))
    np.subtract(command, v[nb:], acceleration[nb:])
    acceleration[nb:] /= plant.motor_time_constant
    rhs = mass[:nb, nb:] @ acceleration[nb:]
    rhs += bias[:nb]
    np.negative(np.linalg.solve(mass[:nb, :nb], rhs), acceleration[:nb])
    torque = mass[nb:, :nb] @ acceleration[:nb]
    torque += mass[nb:, nb:] @ acceleration[nb:]
    torque += bias[nb:]
    return acceleration, torque, mass, bias


def plant_of(name: str) -> Plant:
    if name == "bluerov2_alpha5":  # every term: added mass, damping, a current, buoyancy
        return Plant(shipped(name), gravity=True, current=[0.3, -0.2, 0.1])
    if name == "one_joint":  # a vehicle with a one-joint arm, on a skew axis: products of one row (numpy's dot there)
        return Plant(uvms.load(urdf(axis="0.6 0 0.8", xyz="0.4 0.2 0.1", ixx="0.7", root=FLOATING_ROOT)))
    if name == "hoang2011":  # a planar vehicle (a 3 x 3 solve)
        return Plant(shipped(name))
    def diagonal(*values: float) -> str:
        return " ".join(map(str, np.diag(values).ravel()))

    hull = body_urdf(added=diagonal(1.0, 2.0, 3.0, 0.1, 0.2, 0.3), linear=diagonal(-5.0, -6.0, -7.0, -1.0, -1.0, -1.0))
    return Plant(uvms.load(hull), gravity=True)  # no arm


@pytest.mark.parametrize("name", ["bluerov2_alpha5", "one_joint", "hoang2011", "hull"])
def test_the_compiled_dynamics_are_numpys(name, rng):
    plant = plant_of(name)
    robot, nv = plant.robot, plant.model.nv
    checked = 0
    for _ in range(40):
        q = pin.integrate(robot.model, robot.neutral(), rng.normal(size=nv))
        v, command = rng.normal(size=nv), rng.normal(size=plant.n_arm)
        for wrench in (None, rng.normal(size=6) * 20.0):
            acceleration, torque, mass, bias = numpy_dynamics(plant, q, v, command, wrench)
            dynamics = plant.dynamics(q, v, command, wrench)
            np.testing.assert_array_equal(dynamics.acceleration, acceleration)
            np.testing.assert_array_equal(dynamics.joint_torque, torque)
            np.testing.assert_array_equal(dynamics.mass_matrix, mass)
            np.testing.assert_array_equal(plant.stage_acceleration(q, v, command, wrench), acceleration)
            np.testing.assert_array_equal(plant._mass_and_bias(q, v, wrench)[1], bias)
            checked += wrench is not None and np.abs(bias - plant._mass_and_bias(q, v)[1]).max() > 1.0
    assert checked == 40  # the wrench moved nbar


def test_the_actuated_rate_is_numpys(rng):
    """The thrusters' wrench B f (B column-major, as allocation_matrix makes it) and lag (sat(f_cmd) - f) / tau with
    the plant's dynamics under that wrench: what the numpy expressions give."""
    plant = plant_of("bluerov2_alpha5")
    actuated = ActuatedPlant.of(plant)
    system = actuated.system(None, dt=0.01)
    nv = plant.model.nv
    for _ in range(40):
        q = pin.integrate(plant.model, plant.robot.neutral(), rng.normal(size=nv))
        x = np.concatenate([rng.normal(size=nv), rng.uniform(actuated.lower, actuated.upper)])
        arm, command = rng.normal(size=plant.n_arm), rng.uniform(actuated.lower, actuated.upper)
        dynamics, (_, rate), wrench = system._rate(q, x, arm, command, np.zeros(0))
        expected_wrench = actuated.matrix @ x[nv:]
        acceleration, torque, _, _ = numpy_dynamics(plant, q, x[:nv], arm, expected_wrench)
        np.testing.assert_array_equal(wrench, expected_wrench)
        lag = (command - x[nv:]) / actuated.time_constants
        np.testing.assert_array_equal(rate, np.concatenate([acceleration, lag]))
        np.testing.assert_array_equal(dynamics.joint_torque, torque)
        np.testing.assert_array_equal(system._rate(q, x, arm, command, np.zeros(0), False)[1][1], rate)


def test_numpys_pairwise_sum_is_replicated(rng):
    """numpy's ``sum`` (a loop below 8 entries, eight partial sums up to 128, halves beyond): the same bits at every
    length, the halving's stack included; a plain left-to-right loop differs."""
    from uvms.numerics._kernels.plant_stage import _numpy_sum

    plain_differs = 0
    for count in [*range(0, 140), 255, 256, 257, 1000, 5000]:
        values = rng.normal(size=count) * 10.0 ** rng.uniform(-6, 6, count)
        assert _numpy_sum(values) == float(values.sum())
        plain_differs += sum(values.tolist()) != float(values.sum())
    assert plain_differs > 10


@pytest.mark.parametrize("fins", [False, True])
def test_the_actuation_series_derived_after_the_loop_are_the_per_row_numpy_expressions(fins):
    """The body wrench, thrust powers and motor power a run derives from its stored rows after the loop are what the
    record computed per row with numpy (B f plus the fins' wrench, or plus 0.0 without; f * (B^T nu) summed, nu from
    Pinocchio's actInv; tau_m . qd_m), bit for bit: the torpedo's one thruster (a product of one row) and four fins,
    the BlueROV2 + Alpha 5's eight thrusters and arm."""
    from pathlib import Path

    from uvms.control import OpenLoop
    from uvms.dynamics.hydro.hydrodynamics import hydrodynamics_of
    from uvms.dynamics.plant.actuated import base_twist
    from uvms.errors import BaseGuessWarning, PointMassWarning
    from uvms.sim import simulate

    if fins:
        with pytest.warns(PointMassWarning), pytest.warns(BaseGuessWarning):
            robot = uvms.load(Path(__file__).parents[1] / "fixtures" / "auv" / "torpedo.urdf")
        actuated = ActuatedPlant.of(Plant(robot, hydrodynamics_of(robot), current=[0.2, 0.1, 0.0]))
        controller = OpenLoop(thrust=lambda t: [40.0 * np.sin(3.0 * t)], fins=lambda t: 0.3 * np.sin(t + np.arange(4)))
    else:
        actuated = ActuatedPlant.of(plant_of("bluerov2_alpha5"))
        controller = OpenLoop(arm=lambda t: 0.2 * np.cos(t + np.arange(actuated.plant.n_arm)),
                              thrust=lambda t: 60.0 * np.sin(2.0 * t + np.arange(8)))
    plant = actuated.plant
    result = simulate(actuated, controller, plant.robot.neutral(), 0.5, 0.01)
    series, nb = result.actuation, plant.nb
    v, torques = result.v, result.plant.joint_torque
    for k in range(len(result.t)):
        thrusts = series.thrusts[k]
        fin_wrench = series.controller["fin_wrench"][k] if fins else np.zeros(6)
        powers = thrusts * (actuated.matrix.T @ base_twist(plant, v[k]))
        assert series.body_wrench[k].tobytes() == (actuated.matrix @ thrusts + fin_wrench).tobytes()
        assert series.thrust_power[k] == float(powers.sum())
        assert series.thruster_power_abs[k] == float(np.abs(powers).sum())
        assert series.motor_power[k] == float(torques[k] @ v[k, nb:])
    assert np.abs(series.thrust_power).max() > 1.0 and (fins or np.abs(series.motor_power).max() > 1e-3)


def test_the_thrust_saturation_is_numpys_clip(rng):
    """ActuatedPlant.saturate (compiled) gives np.clip's bytes: values inside, beyond and at the bounds, signed zeros
    at a bound of zero (np.clip returns the bound there), a NaN kept."""
    actuated = ActuatedPlant.of(plant_of("bluerov2_alpha5"))
    lower, upper = actuated.lower.copy(), actuated.upper.copy()
    special = np.array([0.0, -0.0, np.nan, np.inf, -np.inf, *lower[:2], *upper[:2]])
    for trial in range(200):
        actuated.lower, actuated.upper = (lower, upper) if trial % 2 else (np.full(8, -0.0), np.full(8, 0.0))
        command = np.where(rng.random(8) < 0.5, rng.choice(special, 8), rng.normal(size=8) * 60.0)
        assert actuated.saturate(command).tobytes() == np.clip(command, actuated.lower, actuated.upper).tobytes()


def test_a_steps_command_is_checked_and_saturated_as_numpys_clip(rng):
    """finite_clipped_into (an actuated step's command checked and its thrust saturated in one call): np.clip's bytes
    for finite commands (at and beyond the bounds, signed zeros), False (nothing claimed) for a non-finite arm rate or
    thrust."""
    from uvms.numerics._kernels.plant_stage import finite_clipped_into

    actuated = ActuatedPlant.of(plant_of("bluerov2_alpha5"))
    lower, upper = actuated.lower, actuated.upper
    special = np.array([0.0, -0.0, *lower[:2], *upper[:2], 1e300, -1e300])
    for trial in range(300):
        arm = rng.normal(size=5)
        command = np.where(rng.random(8) < 0.5, rng.choice(special, 8), rng.normal(size=8) * 60.0)
        saturated = np.full(8, 7.0)
        if trial % 3 == 0:
            (arm if trial % 2 else command)[trial % 5] = rng.choice([np.nan, np.inf, -np.inf])
            assert not finite_clipped_into(arm, command, lower, upper, saturated)
            continue
        assert finite_clipped_into(arm, command, lower, upper, saturated)
        assert saturated.tobytes() == np.clip(command, lower, upper).tobytes()
