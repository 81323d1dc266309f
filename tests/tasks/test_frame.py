"""The frame task (uvms.tasks.frame): a frame task's terms computed at once equal the terms computed one by one."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

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


def test_the_euler_feedforward_is_the_rate_of_the_target_rpy(rng):
    """The feedforward of an Euler task: [v; rpy rates] of a target turning at omega (world), equal to the finite
    difference of the target's rpy; a target that does not turn gives zero rates."""
    import pinocchio as pin

    robot = uvms.load("bluerov2_alpha5")
    task = uvms.FrameTask(robot, orientation="euler")
    state = Configuration(robot, robot.neutral())
    for omega in (rng.normal(size=3), np.zeros(3)):
        rotation = pin.rpy.rpyToMatrix(*rng.uniform(-1.0, 1.0, size=3))
        twist = np.concatenate([rng.normal(size=3), omega])
        task.set_target(pin.SE3(rotation, np.zeros(3)))
        task.set_target_velocity(twist)
        h = 1e-6
        later, earlier = (pin.rpy.matrixToRpy(pin.exp3(sign * h * omega) @ rotation) for sign in (1.0, -1.0))
        feedforward = task.feedforward(state)
        assert np.array_equal(feedforward[:3], twist[:3])
        assert np.allclose(feedforward[3:], (later - earlier) / (2 * h), atol=1e-8)
        assert np.any(feedforward[3:] != 0.0) == np.any(omega != 0.0)


def test_a_task_following_a_trajectorys_arrays_has_the_terms_of_its_pose_and_keeps_no_view_of_a_set_pose(rng):
    """``follow`` takes the arrays as they are (the rpy given, not recomputed); ``set_target`` copies the pose."""
    import pinocchio as pin

    robot = uvms.load("bluerov2_alpha5")
    for orientation in ("euler", "log"):
        by_pose, by_arrays = (uvms.FrameTask(robot, orientation=orientation) for _ in range(2))
        pose, twist = robot.fk(robot.random_configuration(rng)), rng.normal(size=6)
        by_pose.set_target(pose)
        by_pose.set_target_velocity(twist)
        rotation = np.asfortranarray(pose.rotation)
        by_arrays.follow(pose.translation.copy(), rotation, twist, pin.rpy.matrixToRpy(rotation))
        state = Configuration(robot, robot.random_configuration(rng))
        for ours, theirs in zip(by_arrays.terms(state), by_pose.terms(state)):
            assert np.array_equal(ours, theirs)
        assert np.array_equal(by_arrays.target.homogeneous, pose.homogeneous)
        assert by_arrays.target_terms()[1] is rotation  # taken as it is, not copied
        before = pose.translation.copy()
        pose.translation[0] += 1.0  # the caller's pose changes: the task's target does not
        assert np.array_equal(by_pose.target.translation, before)
    task = uvms.FrameTask(robot, orientation="euler")
    task.follow(np.zeros(3), np.eye(3), np.zeros(6), np.array([0.1, 0.2, 0.3]))  # a given rpy is the one used
    assert np.array_equal(task.target_terms()[2], [0.1, 0.2, 0.3])


def test_position_rows_come_from_the_joint_kinematics_with_the_numbers_of_the_frame_jacobian_and_pose():
    """A task of position rows forms them from the joint kinematics in one compiled call, without placing its frame:
    the rows of getFrameJacobian (world-aligned) and p_d - p of the frame's placement; a task with orientation rows
    still reads them from the frame (Pinocchio's log3)."""
    from uvms.tasks.frame import log_pose_error

    robot = uvms.load("bluerov2_alpha5")
    rng = np.random.default_rng(5)
    for axes in (("x", "y", "z"), ("z", "x"), None):
        task = uvms.FrameTask(robot, axes=axes)
        for _ in range(20):
            q = robot.random_configuration(rng)
            target = robot.fk(robot.random_configuration(rng))
            task.set_target(target)
            task.set_target_velocity(rng.normal(size=6))
            state = Configuration(robot, q)
            jacobian, error, feedforward = task.terms(state)
            assert (task.frame_id in state._placed) == (axes is None)  # position rows: the frame never placed
            expected = Configuration(robot, q)
            np.testing.assert_allclose(jacobian, expected.jacobian(task.frame_id)[task.rows], rtol=1e-15, atol=1e-300)
            np.testing.assert_allclose(error, log_pose_error(target.translation, target.rotation,
                                                             expected.pose(task.frame_id))[task.rows],
                                       rtol=1e-15, atol=1e-300)
            np.testing.assert_allclose(feedforward, task.target_twist[task.rows], rtol=0, atol=0)



def test_euler_rows_come_from_the_joint_kinematics_with_pinocchio_s_numbers_bit_for_bit():
    """A task with Euler orientation rows forms its rows in the same compiled call as position rows: rpy of the
    frame (matrixToRpy), the wrapped rpy error and the rows E(rpy)^-1 J_w (computeRpyJacobianInverse) equal the
    task's own jacobian() and error() bit for bit, pitch near +-pi/2 (matrixToRpy's branch) included."""
    robot = uvms.load("bluerov2_alpha5")
    rng = np.random.default_rng(6)
    for axes in (("x", "y", "yaw"), ("roll", "pitch", "yaw"), None):
        task = uvms.FrameTask(robot, axes=axes, orientation="euler")
        for index in range(60):
            q = robot.random_configuration(rng)
            if index % 2:  # the vehicle pitched to within 1e-12..1e-1 rad of +-pi/2
                pitch = np.pi / 2 * (1 - 10.0 ** rng.uniform(-12, -1)) * rng.choice([-1, 1])
                q[3:7] = pin.Quaternion(pin.rpy.rpyToMatrix(rng.normal(), pitch, rng.normal())).coeffs()
            task.set_target(robot.fk(robot.random_configuration(rng)))
            state = Configuration(robot, q)
            jacobian, error, _ = task.terms(state)
            assert task.frame_id not in state._placed  # formed from the joint kinematics
            expected = Configuration(robot, q)
            assert np.array_equal(jacobian, task.jacobian(expected)) and np.array_equal(error, task.error(expected))
            assert np.abs(error[task.rows >= 3]).max() <= np.pi
