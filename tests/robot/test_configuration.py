"""Configuration (uvms.robot.configuration): its own Pinocchio data, each quantity once per q, update and integrate."""

import numpy as np
import pinocchio as pin
import pytest

import uvms
from uvms import Configuration
from uvms.errors import ConfigurationError


@pytest.fixture(scope="module")
def robot():
    return uvms.load("amundsen2018")


def test_two_configurations_never_share_state(robot):
    """Regression: a state at q1 reported the pose of q2 once a state at q2 existed (one shared pin.Data)."""
    rng = np.random.default_rng(3)
    q1, q2 = robot.random_configuration(rng), robot.random_configuration(rng)
    frame = robot.frame_id()
    first = Configuration(robot, q1)
    pose_1, jacobian_1 = first.pose(frame).copy(), first.jacobian(frame).copy()
    second = Configuration(robot, q2)
    second.pose(frame), second.jacobian(frame), second.centroidal_split()
    assert first.pose(frame).isApprox(pose_1, 0.0) and np.array_equal(first.jacobian(frame), jacobian_1)
    assert np.allclose(first.pose(frame).homogeneous, robot.fk(q1).homogeneous, atol=1e-14)
    assert not np.allclose(second.pose(frame).translation, pose_1.translation)
    assert first.data is not second.data and first.data is not robot.data


def test_the_jacobian_is_the_world_aligned_one_and_is_computed_once(robot):
    q = robot.random_configuration(np.random.default_rng(4))
    configuration = Configuration(robot, q)
    frame = robot.frame_id()
    jacobian = configuration.jacobian(frame)
    assert jacobian is configuration.jacobian(frame)  # the same array: not recomputed
    data = robot.model.createData()
    expected = pin.computeFrameJacobian(robot.model, data, q, frame, pin.LOCAL_WORLD_ALIGNED)
    assert np.allclose(jacobian, expected, rtol=0, atol=1e-13)
    # d(position)/dt = J v, checked by a finite difference along a random velocity
    v, h = np.random.default_rng(5).standard_normal(robot.nv), 1e-6
    ahead = Configuration(robot, pin.integrate(robot.model, q, h * v)).pose(frame).translation
    behind = Configuration(robot, pin.integrate(robot.model, q, -h * v)).pose(frame).translation
    assert np.allclose((ahead - behind) / (2 * h), jacobian[:3] @ v, atol=1e-7)


def test_update_and_integrate_move_it_and_forget_what_was_computed(robot):
    rng = np.random.default_rng(6)
    q, v, dt = robot.random_configuration(rng), rng.standard_normal(robot.nv), 0.01
    frame = robot.frame_id()
    configuration = Configuration(robot, q)
    before = configuration.jacobian(frame).copy()
    configuration.integrate(v, dt)
    assert np.array_equal(configuration.q, pin.integrate(robot.model, q, v * dt))
    assert not np.allclose(configuration.jacobian(frame), before)
    assert np.allclose(configuration.jacobian(frame), Configuration(robot, configuration.q).jacobian(frame), atol=0)
    configuration.update(q)
    assert np.array_equal(configuration.jacobian(frame), before)
    assert np.allclose(configuration.generalized(before), robot.generalized_jacobian(q), atol=1e-12)
    with pytest.raises(ConfigurationError):
        configuration.update(np.full(robot.nq, np.nan))


def test_the_joint_arrays_are_views_of_its_own_data_at_its_current_q(robot):
    """data.J and a joint's placement, as Pinocchio computes them at q; the same views show the next q after an
    update (what a compiled step reads without a Python call per array)."""
    rng = np.random.default_rng(7)
    joint = robot.model.frames[robot.frame_id()].parentJoint
    configuration = Configuration(robot, robot.random_configuration(rng))
    views = configuration.joint_arrays(joint)
    for _ in range(3):
        q = robot.random_configuration(rng)
        configuration.update(q)
        jacobians, translation, rotation = configuration.joint_arrays(joint)
        assert all(a is b for a, b in zip((jacobians, translation, rotation), views))  # made once per joint
        data = robot.model.createData()
        pin.computeJointJacobians(robot.model, data, q)
        assert np.array_equal(jacobians, data.J)
        assert np.array_equal(translation, data.oMi[joint].translation)
        assert np.array_equal(rotation, data.oMi[joint].rotation)
        assert np.array_equal(configuration.pose(robot.frame_id()).homogeneous, robot.fk(q).homogeneous)
