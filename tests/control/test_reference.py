"""TaskReference: a task pointed at its trajectory's target of each time, once per time."""

from __future__ import annotations

import numpy as np

import uvms
from uvms.control.reference import TaskReference
from uvms.tasks import FrameTask
from uvms.trajectory import RecentSamples, TrajectoryTable, VelocityRamps


class CountingRamps:
    """A trajectory that counts how often it is asked (a pure function of time: asking again is waste)."""

    def __init__(self, ramps: VelocityRamps) -> None:
        self.ramps, self.calls = ramps, 0

    def __call__(self, t: float):
        self.calls += 1
        return self.ramps(t)


def test_the_task_takes_the_trajectorys_pose_and_twist_once_per_time():
    robot = uvms.load("hoang2011")
    ramps = VelocityRamps.trapezoid([1.0, 0.5, -0.2], [0.2, -0.1, 0.05], 2.0, 0.5)
    counting = CountingRamps(ramps)
    reference = TaskReference(FrameTask(robot, axes=("x", "y", "z")), counting)
    assert isinstance(reference.samples, RecentSamples) and reference.moving
    assert reference.follow(0.8) is True
    assert reference.follow(0.8) is False and counting.calls == 1  # the same t: not pointed again
    # at t = 0.8 s (cruise after the 0.5 s ramp): p = start + v (t - 0.25) [m], the twist [v; 0]
    np.testing.assert_allclose(reference.task.target.translation, [1.11, 0.445, -0.1725], rtol=0, atol=1e-12)
    np.testing.assert_allclose(reference.task.target_twist, [0.2, -0.1, 0.05, 0, 0, 0], rtol=0, atol=1e-12)
    reference.forget()  # a new run: the same time is pointed at again (from the samples kept)
    assert reference.follow(0.8) is True and counting.calls == 1
    assert reference.follow(1.0) is True and counting.calls == 2


def test_a_tables_rows_give_the_target_of_the_trajectory_itself():
    robot = uvms.load("hoang2011")
    ramps = VelocityRamps.trapezoid([1.0, 0.5, -0.2], [0.2, -0.1, 0.05], 2.0, 0.5)
    times = np.linspace(0.0, 2.0, 21)
    tabled = TaskReference(FrameTask(robot), RecentSamples(TrajectoryTable(ramps, times)))
    called = TaskReference(FrameTask(robot), ramps)
    for t in times[[0, 3, 10, 20]]:
        tabled.follow(float(t)), called.follow(float(t))
        assert tabled.task.target.isApprox(called.task.target, 1e-14)
        np.testing.assert_allclose(tabled.task.target_twist, called.task.target_twist, rtol=0, atol=1e-15)


def test_without_a_trajectory_the_task_keeps_its_target():
    robot = uvms.load("hoang2011")
    task = FrameTask(robot, axes=("x", "y", "z"))
    task.set_target([0.3, -0.2, 0.1, 0.0, 0.0, 0.0])
    reference = TaskReference(task, None)
    assert not reference.moving and reference.follow(1.0) is False
    np.testing.assert_array_equal(task.target.translation, [0.3, -0.2, 0.1])
