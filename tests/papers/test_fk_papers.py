"""Forward kinematics of the paper models against the papers' closed forms."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from conftest import shipped, xiang_eq6


def hoang_closed_form(q_vehicle: np.ndarray, q_arm: np.ndarray, a=0.4, b=0.6, lengths=(0.4, 0.4, 0.3)) -> np.ndarray:
    """x_E, y_E, phi_E of hoang2011 section 3."""
    x, y, psi = q_vehicle
    s1, s12, s123 = psi + q_arm[0], psi + q_arm[0] + q_arm[1], psi + q_arm.sum()
    x_e = (x + a * np.cos(psi) + b * np.sin(psi)
           + lengths[0] * np.sin(s1) + lengths[1] * np.sin(s12) + lengths[2] * np.sin(s123))
    y_e = (y + a * np.sin(psi) - b * np.cos(psi)
           - lengths[0] * np.cos(s1) - lengths[1] * np.cos(s12) - lengths[2] * np.cos(s123))
    return np.array([x_e, y_e, s123 - np.pi / 2])


def test_hoang2011_fk_equals_closed_form(rng):
    robot = shipped("hoang2011")
    lower, upper = robot.arm_limits
    for _ in range(200):
        base = np.array([*rng.uniform(-5, 5, 2), rng.uniform(-np.pi, np.pi)])
        arm = rng.uniform(lower, upper)
        pose = robot.fk(robot.configuration(base=base, arm=arm), "ee")
        expected = hoang_closed_form(base, arm)
        assert np.allclose(pose.translation, [expected[0], expected[1], 0.0], atol=1e-12, rtol=0)
        assert np.allclose(pose.rotation, pin.rpy.rpyToMatrix(0, 0, expected[2]), atol=1e-12, rtol=0)


def test_hoang2011_xacro_args_change_the_kinematics(rng):
    import uvms

    robot = uvms.load("hoang2011", args={"a": 0.5, "b": 0.7, "l1": 0.6, "l3": 0.25})
    for _ in range(20):
        base = np.array([*rng.uniform(-5, 5, 2), rng.uniform(-np.pi, np.pi)])
        arm = rng.uniform(*robot.arm_limits)
        expected = hoang_closed_form(base, arm, a=0.5, b=0.7, lengths=(0.6, 0.4, 0.25))
        assert np.allclose(robot.fk(robot.configuration(base=base, arm=arm)).translation[:2], expected[:2], atol=1e-12)


def test_santos2006_start_pose_matches_paper():
    robot = shipped("santos2006")
    pose = robot.fk(robot.configuration(base=[0.0, 0.0, 0.0], arm=[1.47, -1.0, 0.3]), "ee")
    yaw = pin.rpy.matrixToRpy(pose.rotation)[2]
    assert np.round(pose.translation[0], 2) == 5.92
    assert np.round(pose.translation[1], 2) == 4.29
    assert np.round(yaw, 2) == 0.77
    assert abs(pose.translation[2]) < 1e-15


def test_xiang2019_both_arms_equal_eq6(rng):
    robot = shipped("xiang2019")
    names = robot.arm_joint_names
    lower, upper = robot.arm_limits
    for _ in range(150):
        arm = rng.uniform(lower, upper)
        q = robot.random_configuration(rng)
        q = robot.configuration(base=robot.base_pose(q), arm=arm)
        for side in ("left", "right"):
            theta = np.array([arm[names.index(f"{side}_joint{i}")] for i in range(1, 5)])
            relative = robot.fk(q, f"{side}_base").actInv(robot.fk(q, f"{side}_ee"))
            expected = xiang_eq6(theta)
            assert np.allclose(relative.rotation, expected.rotation, atol=1e-12, rtol=0)
            assert np.allclose(relative.translation, expected.translation, atol=1e-12, rtol=0)


def test_xiang2019_claws_do_not_move_the_dh_frame(rng):
    robot = shipped("xiang2019")
    names = robot.arm_joint_names
    arm = rng.uniform(*robot.arm_limits)
    opened = arm.copy()
    opened[names.index("left_claw")] = 0.0 if arm[names.index("left_claw")] > 0.4 else 0.8
    a, b = robot.configuration(arm=arm), robot.configuration(arm=opened)
    assert np.allclose(robot.fk(a, "left_ee").homogeneous, robot.fk(b, "left_ee").homogeneous, atol=0)
