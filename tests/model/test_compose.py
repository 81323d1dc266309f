"""Composing models (uvms.model.compose): an example-robot-data arm mounted on a vehicle (Pinocchio appendModel)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import uvms

from conftest import ROOT, shipped


@pytest.mark.parametrize("arm_name", ["panda", "ur5", "z1"])
def test_mounted_arm_kinematics_compose(arm_name, rng):
    vehicle = shipped("santos2006")
    placement = pin.SE3(pin.rpy.rpyToMatrix(np.pi, 0.0, 0.3), np.array([2.5, 0.1, -0.5]))
    robot = uvms.model.mount_arm(vehicle, arm_name, placement=placement, prefix="arm_")
    arm = uvms.load(uvms.model.example_robot_urdf(arm_name), base="fixed")  # panda's root link has mass: bolt it down
    assert robot.base_type == "planar"
    assert robot.n_arm == vehicle.n_arm + arm.nv
    arm_mass = sum(inertia.mass for inertia in arm.model.inertias)  # with the fixed root link's own mass
    assert robot.total_mass == pytest.approx(vehicle.total_mass + arm_mass, rel=1e-12)
    arm_ee = arm.ee_frames[0]
    assert robot.ee_frames == ["ee", "arm_" + arm_ee]
    for _ in range(10):
        q = robot.random_configuration(rng)
        q_arm = q[vehicle.nq:]
        expected = robot.fk(q, "base_link") * placement * arm.fk(q_arm, arm_ee)
        assert np.allclose(robot.fk(q, "arm_" + arm_ee).homogeneous, expected.homogeneous, atol=1e-12)
        # the vehicle's own arm is unchanged by the mounting
        assert np.allclose(robot.fk(q, "ee").homogeneous, vehicle.fk(q[: vehicle.nq], "ee").homogeneous, atol=1e-12)


def test_mount_rejects_name_clashes_and_unknown_arms():
    vehicle = shipped("hoang2011")
    once = uvms.model.mount_arm(vehicle, "z1", prefix="left_")
    with pytest.raises(uvms.UVMSError, match="clash"):
        uvms.model.mount_arm(once, "z1", prefix="left_")
    assert uvms.model.mount_arm(once, "z1", prefix="right_").n_arm == vehicle.n_arm + 2 * (once.n_arm - vehicle.n_arm)
    with pytest.raises(uvms.UVMSError, match="fixed root"):
        uvms.model.mount_arm(vehicle, "santos2006")
    with pytest.raises(uvms.errors.ModelFileNotFound, match="available: .*panda"):
        uvms.model.mount_arm(vehicle, "no_such_arm")
    with pytest.raises(uvms.errors.FrameNotFound):
        uvms.model.mount_arm(vehicle, "z1", parent_frame="hull")


def test_mount_placement_as_six_numbers_matches_se3():
    vehicle = shipped("hoang2011")
    values = [0.4, -0.6, 0.1, 0.1, 0.2, 0.3]
    a = uvms.model.mount_arm(vehicle, "z1", placement=values)
    b = uvms.model.mount_arm(vehicle, "z1", placement=pin.SE3(pin.rpy.rpyToMatrix(0.1, 0.2, 0.3), np.array(values[:3])))
    q = a.random_configuration(1)
    assert np.allclose(a.fk(q, a.ee_frames[1]).homogeneous, b.fk(q, b.ee_frames[1]).homogeneous, atol=1e-14)


IDIOMS = ROOT / "tests" / "fixtures" / "joints" / "rov_idioms.urdf"


@pytest.mark.parametrize("arm_joints", [None, []])  # the vehicle with its arm, and the vehicle alone
def test_mount_save_load_keeps_the_end_effectors_and_the_arm_joints(arm_joints, tmp_path, rng):
    vehicle = uvms.load(IDIOMS, arm_joints=arm_joints)  # propellers, sensor mounts, a zero-range joint, mimics
    robot = uvms.model.mount_arm(vehicle, "z1", placement=[0.2, 0.0, -0.4, np.pi, 0.0, 0.0])
    expected = ["arm_tool", "arm_gripperMover"] if arm_joints is None else ["arm_gripperMover"]
    assert robot.ee_frames == expected and robot.ee_reason.count("on the arm of joint") == len(expected)
    assert robot.joint_classes["thruster_0_joint"].kind == "propeller"
    assert robot.joint_classes["arm_joint1"].kind == "arm"
    again = uvms.load(robot.save_urdf(tmp_path / "composed.urdf"))
    assert again.ee_frames == robot.ee_frames and again.arm_joint_names == robot.arm_joint_names
    assert again.mimic_joint_names == robot.mimic_joint_names and list(again.model.names) == list(robot.model.names)
    for _ in range(5):
        q = robot.random_configuration(rng)
        for frame in [*robot.ee_frames, "thruster_1", "finger_c_link"]:
            np.testing.assert_allclose(again.fk(q, frame).homogeneous, robot.fk(q, frame).homogeneous, atol=1e-12)


def test_an_arm_whose_point_mass_moves_nothing_is_refused_once_mounted(tmp_path):
    """A tiny mass with zero inertia on the axis of its own joint: the joint moves no inertia, the composed mass
    matrix is singular, which mount_arm refuses as load does (a point mass off the axis is accepted)."""
    def arm(offset: float) -> str:
        return f"""<robot name="pointy"><link name="mount"/>
          <link name="tip"><inertial><origin xyz="{offset} 0 0"/><mass value="0.001"/>
            <inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial></link>
          <joint name="spin" type="revolute"><parent link="mount"/><child link="tip"/><axis xyz="0 0 1"/>
            <limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>"""

    (tmp_path / "on_axis.urdf").write_text(arm(0.0))
    (tmp_path / "off_axis.urdf").write_text(arm(0.1))
    vehicle = shipped("bluerov2_alpha5")
    with pytest.warns(uvms.errors.PointMassWarning):
        mounted = uvms.model.mount_arm(vehicle, tmp_path / "off_axis.urdf", placement=[0.2, 0, -0.1, 0, 0, 0])
    assert mounted.nv == vehicle.nv + 1
    with pytest.warns(uvms.errors.PointMassWarning), pytest.raises(uvms.errors.ModelCheckError, match="singular"):
        uvms.model.mount_arm(vehicle, tmp_path / "on_axis.urdf", placement=[0.2, 0, -0.1, 0, 0, 0])
