"""The vehicle task (uvms.tasks.vehicle.VehicleTask): its stacked terms are its Jacobian, error and feedforward."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import uvms
from uvms.robot.configuration import Configuration
from uvms.tasks.vehicle import VehicleTask


@pytest.mark.parametrize("keywords", [dict(velocities={"vx": 0.2, "wz": -0.1}), dict(velocities={"vy": 0.3},
                                                                                      heading=0.4, depth=-4.0)])
def test_the_terms_are_the_jacobian_error_and_feedforward_and_follow_the_imposed_velocities(rng, keywords):
    """Velocities alone: the constant selection rows, no error, the imposed values (a fresh copy: setting the values
    after does not change terms already taken); with a heading and a depth their rows read the pose."""
    robot = uvms.load("bluerov2_alpha5")
    task = VehicleTask(robot, **keywords)
    state = Configuration(robot, pin.integrate(robot.model, robot.neutral(), 0.3 * rng.normal(size=robot.nv)))
    jacobian, error, feedforward = task.terms(state)
    assert np.array_equal(jacobian, task.jacobian(state)) and np.array_equal(error, task.error(state))
    assert np.array_equal(feedforward, task.feedforward(state))
    velocities = keywords["velocities"]
    names = ["vx", "vy", "vz", "wx", "wy", "wz"]
    for row, name in enumerate(velocities):
        assert jacobian[row, names.index(name)] == 1.0 and jacobian[row].sum() == 1.0
    assert feedforward[:len(velocities)].tolist() == list(velocities.values())
    task.velocity_values[:] = 7.0
    assert feedforward[:len(velocities)].tolist() == list(velocities.values())
    assert task.terms(state)[2][:len(velocities)].tolist() == [7.0] * len(velocities)
    if "heading" in keywords:
        assert error[-2] != 0.0 and error[-1] != 0.0  # the pose read: the heading and depth errors
