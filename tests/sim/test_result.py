"""Simulation results (uvms.sim.result): the derived series follow the configurations."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import uvms


def test_the_vehicle_pose_and_arm_series_of_a_result_follow_its_configurations(rng):
    from uvms.sim.result import SimulationResult

    robot = uvms.load("bluerov2_alpha5")
    rows = np.array([robot.random_configuration(rng) for _ in range(4)])
    result = SimulationResult(t=np.arange(4.0), q=rows, v=np.zeros((4, robot.nv)), robot=robot)
    expected = np.array([robot.base_values(q) for q in rows])
    expected[:, 3:6] = np.unwrap(expected[:, 3:6], axis=0)
    assert np.array_equal(result.vehicle_pose(), expected)
    assert np.array_equal(result.arm(), np.array([robot.arm_configuration(q) for q in rows]))
    with pytest.raises(dataclasses.FrozenInstanceError):  # built once, never changed
        result.q = rows[::-1].copy()
    reversed_rows = dataclasses.replace(result, q=rows[::-1].copy())  # a new result: its series computed again
    assert np.array_equal(reversed_rows.vehicle_pose()[0, :3], robot.base_values(rows[-1])[:3])
    assert np.array_equal(result.vehicle_pose(), expected)
