"""Robot facts in one place (uvms.robot.robot, uvms.robot.bases): the base table, joint lookup, base values, the URDF
parsed once."""

from __future__ import annotations

import numpy as np
import pytest

import uvms
from uvms.robot.bases import BASE_TYPES


@pytest.mark.parametrize("name", ["hoang2011", "xiang2019"])
def test_base_values_invert_configuration(name, rng):
    robot = uvms.load(name)
    for _ in range(50):
        values = rng.uniform(-1.0, 1.0, robot.n_vehicle)  # angles inside (-pi/2, pi/2): a unique rpy
        q = robot.configuration(base=values, arm=np.zeros(robot.n_arm))
        assert robot.base_values(q) == pytest.approx(values, abs=1e-12)
    assert len(robot.base_values(robot.neutral())) == len(robot.base.pose_names) == robot.n_vehicle


def test_base_table_matches_pinocchio():
    for name, base in BASE_TYPES.items():
        if base.root_joint is not None:
            joint = base.root_joint()
            assert (joint.nq, joint.nv) == (base.nq, base.nv), name
        assert len(base.velocity_names) == len(base.velocity_labels) == base.nv
        assert len(base.pose_names) == len(base.pose_labels) == base.nv
    robot = uvms.load("santos2006")
    assert robot.base is BASE_TYPES["planar"] and robot.base.task_axes == ("x", "y", "yaw")


def test_joint_lookup_and_urdf_root():
    robot = uvms.load("xiang2019")
    joint = robot.joint(robot.arm_joint_names[2])
    assert joint.name == robot.arm_joint_names[2] and joint.idx_q == robot.model.idx_qs[robot.joint_id(joint.name)]
    with pytest.raises(uvms.errors.JointNotFound, match="close names"):
        robot.joint(robot.arm_joint_names[2] + "x")
    assert robot.urdf_root is robot.urdf_root  # parsed once
    assert len(robot.urdf_root.findall("link")) == robot.urdf.count("<link ") > 8


def test_a_run_checks_its_configurations_once_and_refuses_a_bad_row_by_its_index(rng):
    robot = uvms.load("bluerov2_alpha5")
    rows = np.array([robot.random_configuration(rng) for _ in range(5)])
    assert np.array_equal(robot.check_configurations(rows), rows)
    bad = rows.copy()
    bad[3, 3:7] *= 1.5  # the vehicle's quaternion of row 3
    with pytest.raises(uvms.UVMSError, match="row 3: the rotation part of joint .* has norm 1.5"):
        robot.check_configurations(bad)
    bad = rows.copy()
    bad[1, -1] = np.nan
    with pytest.raises(uvms.UVMSError, match="non-finite"):
        robot.check_configurations(bad)


def test_base_placement_puts_the_root_link_where_the_kinematics_does(rng):
    """``base_pose(q) * base_placement`` is the root link's pose (Pinocchio's frame placement), for a vehicle joint
    placed away from the world origin (0.1 m and a yaw) and for the shipped BlueROV2; it is a copy."""
    import pinocchio as pin

    from conftest import FLOATING_ROOT, urdf

    placed_joint = FLOATING_ROOT.replace('type="floating">', 'type="floating"><origin xyz="0.1 0 0" rpy="0 0 0.3"/>')
    for robot in (uvms.load("bluerov2_alpha5"), uvms.load(urdf(root=placed_joint))):
        q = robot.random_configuration(rng)
        expected = robot.fk(q, robot.root_link)
        placement = robot.base_placement
        assert isinstance(placement, pin.SE3)
        np.testing.assert_allclose((robot.base_pose(q) * placement).homogeneous, expected.homogeneous, atol=1e-12)
        placement.translation = np.full(3, 5.0)  # a copy: the model is not changed
        np.testing.assert_allclose(robot.fk(q, robot.root_link).homogeneous, expected.homogeneous, atol=1e-12)


def test_configuration_takes_the_arm_as_a_table_of_joints_the_others_at_zero():
    robot = uvms.load("hoang2011")
    names = robot.arm_joint_names
    q = robot.configuration(base=np.array([1.0, 2.0, 0.3]), arm={names[2]: -0.4, names[0]: 0.7})
    np.testing.assert_array_equal(robot.arm_configuration(q), [0.7, 0.0, -0.4])
    np.testing.assert_array_equal(q, robot.configuration(base=np.array([1.0, 2.0, 0.3]), arm=[0.7, 0.0, -0.4]))
    with pytest.raises(uvms.errors.NameNotFound, match="unknown arm joint 'elbow'; valid names: q1, q2, q3"):
        robot.configuration(arm={"elbow": 0.1})
    with pytest.raises(uvms.errors.ConfigurationError, match="arm joint values must be a vector of 3 numbers"):
        robot.configuration(arm={names[1]: "up"})


@pytest.mark.parametrize("name", ["hoang2011", "xiang2019", "bluerov2_alpha5"])
def test_base_values_of_rows_are_base_pose_and_matrix_to_rpy_row_by_row(name, rng):
    """``base_values_rows`` (a run's vehicle series) gives each row the numbers of ``base_pose`` and Pinocchio's
    ``matrixToRpy`` bit for bit, planar and floating, at any angle; a fixed base gives (N, 0)."""
    import pinocchio as pin

    robot = uvms.load(name)
    rows = np.array([robot.configuration(base=rng.uniform(-4.0, 4.0, robot.n_vehicle), arm=np.zeros(robot.n_arm))
                     for _ in range(200)])
    values = robot.base_values_rows(rows)
    for q, row in zip(rows, values):
        pose = robot.base_pose(q)
        rpy = pin.rpy.matrixToRpy(pose.rotation)
        expected = [*pose.translation[:2], rpy[2]] if robot.base_type == "planar" else [*pose.translation, *rpy]
        assert np.array_equal(row, expected)
        assert np.array_equal(robot.base_values(q), row)
    fixed = uvms.load(uvms.model.example_robot_urdf("ur5"), base="fixed")
    assert fixed.base_values_rows(np.tile(fixed.neutral(), (3, 1))).shape == (3, 0)
