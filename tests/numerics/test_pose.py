"""The pose kernels (uvms.numerics._kernels.pose): Pinocchio's log3 ported operation by operation, and a frame
task's rows from the joint kinematics, against Pinocchio's own functions."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import uvms
from uvms.numerics._kernels.pose import frame_rows_into, log3_into
from uvms.solvers.clik import support_columns

from conftest import shipped


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
                                rows, target.translation, target.rotation, jacobian, got)
                assert np.array_equal(jacobian, expected)
                assert np.array_equal(got, error)
        if name == "xiang2019":  # the other arm's joints do not move this frame
            other = np.setdiff1d(np.arange(robot.n_vehicle, model.nv), columns)
            assert other.size and np.all(jacobian[:, other] == 0.0)
