"""What a model's structure says (uvms.robot.structure): one default end effector per arm and the rule that chose it,
the names of sensors, the joint classes of a Robot built from a Pinocchio model."""

from __future__ import annotations

import re

import pytest

import uvms
from uvms.robot.structure import EE_GIVEN, default_end_effectors, sensor_word

from conftest import ROOT, SHIPPED, shipped

IDIOMS = (ROOT / "tests" / "fixtures" / "joints" / "rov_idioms.urdf").read_text()
WRIST_CAMERA = ('<link name="wrist_camera_link"/><joint name="wrist_camera_joint" '
                'type="revolute"><parent link="link6"/>'
                '<child link="wrist_camera_link"/><limit lower="0" upper="0" effort="0" velocity="0"/></joint></robot>')


def without_tool(text: str) -> str:
    return re.sub(r'<link name="arm_tool"/>.*?</joint>', "", text, flags=re.S)


def test_the_end_effector_is_the_frame_named_like_one_on_the_arm_else_its_last_leaf_never_a_sensor():
    robot = uvms.load(IDIOMS)
    assert robot.ee_frames == ["arm_tool"]
    assert robot.ee_reason == "'arm_tool' (named like an end effector: 'tool' or '*_tool') on the arm of joint 'j1'"
    leaf = uvms.load(without_tool(IDIOMS).replace("</robot>", WRIST_CAMERA))  # the camera is the last leaf link
    assert leaf.ee_frames == ["finger_c_link"]
    assert leaf.ee_reason.startswith("'finger_c_link' (its last leaf link; no frame is named end_effector, tool, tcp")
    vehicle = uvms.load(IDIOMS, arm_joints=[])  # propellers and sensors are leaves of the vehicle, never its ee
    assert vehicle.ee_frames == ["base_link"]
    assert vehicle.ee_reason == "'base_link', the vehicle's root link: the model has no arm joint"
    assert uvms.load(IDIOMS, ee="link3").ee_reason == EE_GIVEN


def test_names_win_in_their_order_and_each_arm_has_its_end_effector():
    tcp = without_tool(IDIOMS).replace("</robot>", '<link name="hand_tcp"/><link name="hand_ee"/><joint name="t" '
                                                   'type="fixed"><parent link="link6"/><child link="hand_tcp"/></joint>'
                                                   '<joint name="e" type="fixed"><parent link="link6"/><child '
                                                   'link="hand_ee"/></joint></robot>')
    assert uvms.load(tcp).ee_frames == ["hand_tcp"]  # tcp before ee
    assert shipped("xiang2019").ee_frames == ["left_ee", "right_ee"]
    assert shipped("xiang2019").ee_reason.count("named like an end effector: 'ee' or '*_ee'") == 2


@pytest.mark.parametrize("name", SHIPPED)
def test_the_shipped_models_keep_their_end_effectors(name):
    expected = {"xiang2019": ["left_ee", "right_ee"]}.get(name, ["ee"])
    robot = shipped(name)
    assert robot.ee_frames == expected
    assert default_end_effectors(robot.model)[0] == expected
    assert all(joint_class.kind == "arm" for joint_class in robot.joint_classes.values())


def test_example_arms_keep_their_end_effectors_and_mimics_are_no_arm_joints():
    expected = {"panda": "panda_hand_tcp", "ur5": "tool0", "z1": "gripperMover"}
    for arm, frame in expected.items():
        assert uvms.load(uvms.model.example_robot_urdf(arm), base="fixed").ee_frames == [frame]
    panda = uvms.load(uvms.model.example_robot_urdf("panda"), base="fixed")
    assert panda.n_arm == len(panda.arm_joint_names) == 8
    assert panda.mimic_joint_names == ["panda_finger_joint2"]
    assert panda.joint_classes["panda_finger_joint2"].reason == \
        "follows 'panda_finger_joint1': q = 1 q(panda_finger_joint1) + 0"
    bare = uvms.Robot(panda.model)  # from a Pinocchio model alone: its moving joints are what it has
    assert bare.joint_classes["panda_finger_joint2"].kind == "mimic"
    assert bare.joint_classes["panda_joint1"].reason == "a moving joint of the Pinocchio model"


def test_sensor_words_are_whole_words_of_a_name():
    assert sensor_word("rexrov/dvl_sonar2_link") == "dvl"
    assert sensor_word("camera1_link_optical") == "camera"
    assert sensor_word("rexrov/cc_sensor_link") == "sensor"
    assert sensor_word("duo3d_left_link") == "duo3d"
    assert sensor_word("arm_camshaft") is None and sensor_word("imuse") is None and sensor_word("link6") is None
