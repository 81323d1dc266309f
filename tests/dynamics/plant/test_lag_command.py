"""The one-step inverse of a first-order lag (uvms.dynamics.plant.actuated.lag_command): the arm's servos reach the
rate asked at the step's end, and the plant's own servo agrees."""

from __future__ import annotations

import numpy as np

import uvms
from uvms.dynamics.plant.actuated import lag_command
from uvms.dynamics.plant.plant import Plant


def test_a_held_command_brings_the_lag_to_the_wanted_rate_in_one_step():
    rate, wanted, dt, tau = np.array([0.0, 0.3, -0.2]), np.array([0.5, 0.3, 0.1]), 0.02, np.array([0.1, 0.05, 0.2])
    command = lag_command(rate, wanted, dt, tau)
    end = command + (rate - command) * np.exp(-dt / tau)  # x(dt) of x' = (u - x) / tau, u held
    np.testing.assert_allclose(end, wanted, atol=1e-12)
    assert command[1] == 0.3 and command[0] > 5 * wanted[0]  # at the rate already: no lead; 1 / (1 - e^-0.2) = 5.5


def test_the_plant_servo_reaches_the_rate_one_step_after_the_command():
    """The Plant's arm (qdd = (u - qd) / tau) integrated over one step of 0.02 s with RK4 substeps: within 1e-6."""
    robot = uvms.load("bluerov2_alpha5")
    plant = Plant(robot, motor_time_constant=0.1)
    q = robot.configuration(base=[0.0, 0.0, -5.0, 0.0, 0.0, 0.0], arm=[3.0, 1.8, 1.8, 1.0, 0.0])
    v = np.zeros(robot.nv)
    wanted = np.array([0.2, -0.3, 0.4, 0.0, 0.0])
    command = lag_command(v[6:], wanted, 0.02, plant.motor_time_constant)
    h = 0.02 / 20
    for _ in range(20):  # the arm's rates obey their own ODE whatever the vehicle does
        k1 = plant.evaluate(q, v, command).acceleration[6:]
        k2 = (command - (v[6:] + 0.5 * h * k1)) / 0.1
        k3 = (command - (v[6:] + 0.5 * h * k2)) / 0.1
        k4 = (command - (v[6:] + h * k3)) / 0.1
        v = v.copy()
        v[6:] += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    np.testing.assert_allclose(v[6:], wanted, atol=1e-6)
