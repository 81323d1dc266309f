"""The pose kernels (uvms.numerics._kernels.pose): Pinocchio's log3 and SE3 arithmetic ported operation by operation,
and a frame task's rows from the joint kinematics, against Pinocchio's own functions."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import uvms
from uvms.numerics._kernels.pose import action_into, compose_into, frame_rows_into, log3_into, matrix_to_rpy
from uvms.robot.configuration import Configuration
from uvms.robot.kinematics import support_columns

from conftest import shipped, signed_numbers


def test_the_ported_log3_is_pinocchios_bit_for_bit(rng):
    """Every branch of pinocchio::log3: the expansion near 0, acos, the expansion and the axis near pi, and the
    renormalization of a matrix that is not quite a rotation."""
    out = np.empty(3)
    for angle in (0.0, 1e-9, 1e-6, 1e-5, 1e-3, 0.5, 2.0, 3.1, np.pi - 1e-5, np.pi - 1e-7, np.pi):
        for _ in range(40):
            axis = rng.normal(size=3)
            rotation = pin.exp3(angle * axis / np.linalg.norm(axis))
            for matrix in (rotation, rotation + 1e-9 * rng.normal(size=(3, 3))):
                log3_into(matrix, out)
                assert np.array_equal(out, pin.log3(matrix)), (angle, out, pin.log3(matrix))
    log3_into(np.eye(3), out)
    assert np.array_equal(out, np.zeros(3))


def product_in_order(left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """left @ right (3, 3), each entry summed in index order in Python floats."""
    return np.array([[(left[i, 0] * right[0, j] + left[i, 1] * right[1, j]) + left[i, 2] * right[2, j]
                      for j in range(3)] for i in range(3)])


@pytest.mark.parametrize("name", ["ur5", "xiang2019", "hoang2011"])
def test_a_frame_tasks_rows_are_pinocchios_frame_jacobian_and_pose_error(name, rng):
    """The world-aligned Jacobian from data.J and the frame's placement is getFrameJacobian's bit for bit (zero
    on the columns of another branch: xiang2019's two arms), the error [p_d - p; log3(R_d R^T)] too, with R_d R^T
    summed in index order (BLAS may sum otherwise: a last bit that log3 magnifies by 1 / sin(angle) near pi)."""
    robot = (uvms.load(uvms.model.example_robot_urdf("ur5"), base="floating") if name == "ur5" else shipped(name))
    model, data = robot.model, robot.model.createData()
    for frame_name in robot.ee_frames:
        frame_id = robot.frame_id(frame_name)
        joint = model.frames[frame_id].parentJoint
        placement = np.ascontiguousarray(model.frames[frame_id].placement.homogeneous)
        columns = support_columns(model, joint)
        for rows in (np.arange(6), np.array([0, 2, 5])):
            for _ in range(20):
                q = robot.random_configuration(rng)
                target = robot.fk(robot.random_configuration(rng), frame_name)
                pin.computeJointJacobians(model, data, q)
                pin.updateFramePlacements(model, data)
                expected = pin.getFrameJacobian(model, data, frame_id, pin.LOCAL_WORLD_ALIGNED)[rows]
                pose = data.oMf[frame_id]
                error = np.concatenate([target.translation - pose.translation,
                                        pin.log3(product_in_order(target.rotation, pose.rotation.T))])[rows]
                jacobian, got = np.empty((rows.size, model.nv)), np.empty(rows.size)
                frame_rows_into(data.J, data.oMi[joint].translation, data.oMi[joint].rotation, placement, columns,
                                rows, target.translation, target.rotation, np.zeros(0), jacobian, got)
                assert np.array_equal(jacobian, expected)
                assert np.array_equal(got, error)
        if name == "xiang2019":  # the other arm's joints do not move this frame
            other = np.setdiff1d(np.arange(robot.n_vehicle, model.nv), columns)
            assert other.size and np.all(jacobian[:, other] == 0.0)


def test_the_ported_matrix_to_rpy_is_pinocchios_bit_for_bit(rng):
    """Every branch: pitch past pi/2 folded back, yaw of either sign, planar rotations about z."""
    rotations = [pin.exp3(rng.normal(size=3) * scale) for scale in (0.01, 1.0, 3.0, 10.0) for _ in range(200)]
    rotations += [pin.rpy.rpyToMatrix(0.0, 0.0, yaw) for yaw in rng.uniform(-4, 4, 200)]
    for rotation in rotations:
        assert np.array_equal(np.array(matrix_to_rpy(rotation)), pin.rpy.matrixToRpy(rotation))


@pytest.mark.parametrize("name", ["hoang2011", "bluerov2_alpha5"])
def test_a_frame_tasks_euler_rows_are_the_tasks_terms_bit_for_bit(name, rng):
    """The Euler error (rpy_d - rpy wrapped) and the rows E(rpy)^-1 J_omega are FrameTask.terms' numbers."""
    robot = shipped(name)
    model = robot.model
    axes = ("x", "y", "yaw") if name == "hoang2011" else ("x", "z", "roll", "pitch", "yaw")
    task = uvms.FrameTask(robot, axes=axes, orientation="euler")
    frame = model.frames[task.frame_id]
    placement = np.ascontiguousarray(frame.placement.homogeneous)
    columns = support_columns(model, frame.parentJoint)
    rows = np.asarray(task.rows, dtype=np.int64)
    for _ in range(40):
        task.set_target(robot.fk(robot.random_configuration(rng)))
        state = Configuration(robot, robot.random_configuration(rng))
        expected_jacobian, expected_error, _ = task.terms(state)
        translation, rotation, target_rpy, _ = task.target_terms()
        joint_jacobians, joint_translation, joint_rotation = state.joint_arrays(frame.parentJoint)
        jacobian, error = np.empty((task.dim, model.nv)), np.empty(task.dim)
        frame_rows_into(joint_jacobians, joint_translation, joint_rotation, placement, columns, rows, translation,
                        rotation, target_rpy, jacobian, error)
        assert np.array_equal(jacobian, expected_jacobian) and np.array_equal(error, expected_error)



def test_the_se3_product_and_action_are_pinocchios_bit_for_bit(rng):
    """M * M_p and M.act(Motion) as Pinocchio computes them (Eigen sums rows 0-1 and row 2 of a 3x3 product in
    different orders: one order for all three rows differs on row 2 in about a third of the products), signed
    zeros included; the identity (the shipped vehicles' base placement) among them."""
    rotation, translation, twist = np.empty((3, 3)), np.empty(3), np.empty(6)
    row_two = 0
    for trial in range(4000):
        placement = pin.SE3.Random() if trial % 3 else pin.SE3.Identity()
        if trial % 4 == 0:
            placement.translation = signed_numbers(rng, 3)
        pose = pin.SE3.Random()
        pose.translation = signed_numbers(rng, 3)
        composed = pose * placement
        compose_into(pose.rotation, pose.translation, placement.rotation, placement.translation, rotation, translation)
        assert composed.rotation.tobytes() == np.asfortranarray(rotation).tobytes()
        assert composed.translation.tobytes() == translation.tobytes()
        in_order = product_in_order(pose.rotation, placement.rotation)
        row_two += not np.array_equal(in_order[2], rotation[2])
        motion = signed_numbers(rng, 6)
        action_into(placement.rotation, placement.translation, motion[:3], motion[3:], twist)
        assert twist.tobytes() == placement.act(pin.Motion(motion)).vector.tobytes()
    assert row_two > 300  # the order matters: a port summing every row alike would fail


def test_a_frame_tasks_rows_at_a_frame_placed_at_any_angle_are_pinocchios(rng):
    """A frame fixed to a joint at a generic placement (not the axis-aligned ones of the shipped models): its pose is
    Pinocchio's SE3 product oMi * placement in Eigen's order of sums (a row's sums differ from left-to-right in
    about two thirds of random products), so the rows equal getFrameJacobian's and the error oMf's bit for bit."""
    robot = uvms.load(uvms.model.example_robot_urdf("ur5"), base="floating")
    model = robot.model.copy()
    joint = model.njoints - 1
    placement = pin.SE3(pin.rpy.rpyToMatrix(*rng.uniform(-3, 3, 3)), rng.uniform(-0.3, 0.3, 3))
    frame_id = model.addFrame(pin.Frame("tilted_tool", joint, 0, placement, pin.FrameType.OP_FRAME))
    data, columns, rows = model.createData(), support_columns(model, joint), np.arange(6)
    for _ in range(50):
        q = pin.randomConfiguration(model, -np.ones(model.nq), np.ones(model.nq))
        target = pin.SE3.Random()
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        pose = data.oMf[frame_id]
        jacobian, got = np.empty((6, model.nv)), np.empty(6)
        frame_rows_into(data.J, data.oMi[joint].translation, data.oMi[joint].rotation,
                        np.ascontiguousarray(placement.homogeneous), columns, rows, target.translation,
                        target.rotation, np.zeros(0), jacobian, got)
        assert np.array_equal(jacobian, pin.getFrameJacobian(model, data, frame_id, pin.LOCAL_WORLD_ALIGNED))
        assert np.array_equal(got[:3], target.translation - pose.translation)
        assert np.array_equal(got[3:], pin.log3(product_in_order(target.rotation, pose.rotation.T)))
