"""The frame task (uvms.tasks.frame): a frame task's terms computed at once equal the terms computed one by one."""

from __future__ import annotations

import numpy as np

import uvms
from uvms.robot.configuration import Configuration


def test_a_frame_task_computes_its_three_terms_at_once_as_separately(rng):
    robot = uvms.load("bluerov2_alpha5")
    for orientation, axes in (("euler", ("x", "z", "roll", "yaw")), ("log", None), ("euler", ("x", "y", "z"))):
        task = uvms.FrameTask(robot, axes=axes, orientation=orientation)
        for _ in range(10):
            task.set_target(robot.fk(robot.random_configuration(rng)))
            task.set_target_velocity(rng.normal(size=6))
            state = Configuration(robot, robot.random_configuration(rng))
            jacobian, error, feedforward = task.terms(state)
            assert np.array_equal(jacobian, task.jacobian(state))
            assert np.array_equal(error, task.error(state))
            assert np.array_equal(feedforward, task.feedforward(state))
            if orientation == "euler" and "yaw" in axes:  # the yaw row is a wrapped angle difference
                assert -np.pi <= error[-1] < np.pi
