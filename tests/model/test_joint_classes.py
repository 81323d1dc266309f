"""Joint classes (uvms.model.joint_classes): propellers, sensor mounts and zero-range joints frozen, mimic chains
composed, the arm_joints= override; on tests/fixtures/joints/rov_idioms.urdf (uuv_simulator's idioms)."""

from __future__ import annotations

import re

import numpy as np
import pinocchio as pin
import pytest

import uvms
from uvms.dynamics.thrusters.thrusters import allocation_matrix, thrusters_of
from uvms.errors import ModelCheckError, NameNotFound, ThrusterFileWarning

from conftest import ROOT, urdf

IDIOMS = ROOT / "tests" / "fixtures" / "joints" / "rov_idioms.urdf"
ARM = ["j1", "j2", "j3", "j4", "j5", "j6", "finger_a"]
SENSORS = ["rov/dvl_joint", "rov/dvl_sonar0_joint", "rov/imu_joint", "rov/camera_joint", "rov/camera_optical_joint",
           "rov/pressure_joint"]


@pytest.fixture(scope="module")
def rov() -> uvms.Robot:
    return uvms.load(IDIOMS)


def pose(xyz=(0.0, 0.0, 0.0), rpy=(0.0, 0.0, 0.0)) -> pin.SE3:
    return pin.SE3(pin.rpy.rpyToMatrix(*rpy), np.array(xyz, dtype=float))


def turn(axis, angle: float) -> pin.SE3:
    return pin.SE3(pin.exp3(np.array(axis, dtype=float) * angle), np.zeros(3))


def test_the_arm_is_six_joints_and_a_gripper_and_every_other_joint_has_its_class(rov):
    assert rov.n_arm == 7 == len(rov.arm_joint_names) and rov.arm_joint_names == ARM
    assert rov.mimic_joint_names == ["finger_b", "finger_c"]
    kinds = {name: joint_class.kind for name, joint_class in rov.joint_classes.items()}
    assert kinds == {"thruster_0_joint": "propeller", "thruster_1_joint": "propeller",
                     **dict.fromkeys(SENSORS, "sensor"), "anchor": "fixed by range", **dict.fromkeys(ARM, "arm"),
                     "finger_b": "mimic", "finger_c": "mimic"}
    reasons = {name: joint_class.reason for name, joint_class in rov.joint_classes.items()}
    assert "thruster plugin 'thruster_0' names it (<jointName>)" in reasons["thruster_0_joint"]
    assert "'thruster_1' is the <linkName> of uuv_simulator thruster plugin 'thruster_1'" in reasons["thruster_1_joint"]
    assert reasons["rov/dvl_sonar0_joint"] == ("zero range [0, 0], 'rov/dvl_sonar0_link' named like a sensor (dvl); "
                                               "held at 0")
    assert reasons["rov/pressure_joint"].startswith("'rov/pressure_link' named like a sensor (pressure) and no mass")
    assert reasons["anchor"] == "limits [0.2, 0.2]: upper - lower <= 1e-09; held at 0.2"
    assert reasons["finger_c"] == "follows 'finger_a' (composed through finger_b): q = -0.5 q(finger_a) + 0.1"
    assert rov.joint_classes["anchor"].value == 0.2 and not rov.joint_classes["j1"].frozen
    with pytest.raises(TypeError):
        rov.joint_classes["j1"] = rov.joint_classes["anchor"]  # read-only
    assert rov.nv == 6 + 7 and rov.nq == 7 + 7  # no continuous propeller left in q
    assert 'type="continuous"' not in rov.urdf and 'joint="finger_b"' not in rov.urdf  # what Pinocchio built


def test_a_zero_range_joint_is_held_at_its_value_and_the_frames_of_frozen_links_stay(rov, rng):
    for _ in range(5):
        q = rov.random_configuration(rng)
        base = rov.fk(q, "base_link")
        j1 = rov.arm_configuration(q)[0]
        expected = base * pose([0.7, 0, -0.3]) * turn([0, 0, 1], 0.2) * pose([0.1, 0, 0]) * turn([0, 0, 1], j1)
        np.testing.assert_allclose(rov.fk(q, "link1").homogeneous, expected.homogeneous, atol=1e-12)
        optical = base * pose([0.6, 0, 0.1]) * pose(rpy=[-1.5708, 0, -1.5708])
        np.testing.assert_allclose(rov.fk(q, "rov/camera_link_optical").homogeneous, optical.homogeneous, atol=1e-12)
        np.testing.assert_allclose(rov.fk(q, "thruster_1").homogeneous,
                                   (base * pose([-0.5, -0.3, 0], [0, 0, -0.3])).homogeneous, atol=1e-12)


def test_a_chained_mimic_moves_as_the_composed_relation(rov, rng):
    for _ in range(10):
        q = rov.random_configuration(rng)
        finger = rov.arm_configuration(q)[6]
        wrist = rov.fk(q, "link6")
        b = wrist * pose([0.05, -0.02, 0]) * turn([0, 0, 1], -finger)  # q_b = -q_a
        c = wrist * pose([0.05, 0, 0.02], [0.3, 0, 0]) * turn([0, 1, 0], 0.5 * -finger + 0.1)  # q_c = 0.5 q_b + 0.1
        np.testing.assert_allclose(rov.fk(q, "finger_b_link").homogeneous, b.homogeneous, atol=1e-12)
        np.testing.assert_allclose(rov.fk(q, "finger_c_link").homogeneous, c.homogeneous, atol=1e-12)


def test_thrusters_on_frozen_propellers_push_along_their_joint_axis(rov):
    thrusters = thrusters_of(rov)
    assert thrusters.names == ["thruster_0", "thruster_1"]
    directions = np.array([[np.cos(0.3), np.sin(0.3), 0.0], [np.cos(0.3), -np.sin(0.3), 0.0]])
    points = np.array([[-0.5, 0.3, 0.0], [-0.5, -0.3, 0.0]])
    expected = np.vstack([directions.T, np.cross(points, directions).T])
    np.testing.assert_allclose(allocation_matrix(rov, thrusters), expected, atol=1e-12)


PROPELLER_ROV = urdf(root='<link name="world"/><joint name="float" type="floating"><parent link="world"/>'
                          '<child link="base_link"/></joint>',
                     extra='<link name="aft_link"/><joint name="aft_joint" type="continuous"><parent '
                           'link="base_link"/><child link="aft_link"/><axis xyz="1 0 0"/></joint>')


def test_a_thrusters_yaml_beside_the_model_names_propellers(tmp_path):
    (tmp_path / "rov.urdf").write_text(PROPELLER_ROV)
    assert uvms.load(tmp_path / "rov.urdf").joint_classes["aft_joint"].kind == "arm"  # nothing says it pushes
    (tmp_path / "thrusters.yaml").write_text("thrusters:\n  aft: {frame: aft_link, max_forward: 5, max_reverse: 4, "
                                             "time_constant: 0.1}\n")
    robot = uvms.load(tmp_path / "rov.urdf")
    assert robot.joint_classes["aft_joint"].reason == ("its link 'aft_link' is the frame of thruster 'aft' in "
                                                        "thrusters.yaml; held at 0")
    assert robot.arm_joint_names == ["j1"]
    (tmp_path / "thrusters.yaml").write_text("thrusters: [unclosed\n")
    with pytest.warns(ThrusterFileWarning, match="thrusters.yaml: malformed YAML.*propellers it names are not known"):
        assert uvms.load(tmp_path / "rov.urdf").joint_classes["aft_joint"].kind == "arm"


def test_arm_joints_keeps_exactly_the_listed_joints_and_freezes_the_others(rov, rng):
    five = uvms.load(IDIOMS, arm_joints=["j1", "j2", "j3", "j4", "j5", "finger_a"])
    assert five.arm_joint_names == ["j1", "j2", "j3", "j4", "j5", "finger_a"] and five.n_arm == 6
    held = five.joint_classes["j6"]
    assert (held.kind, held.value, held.reason) == ("frozen", 0.3, "not in arm_joints: held at 0.3")  # 0 is outside
    assert five.joint_classes["anchor"].kind == "fixed by range"  # the other frozen joints keep their class
    for _ in range(10):
        q = five.random_configuration(rng)
        arm = five.arm_configuration(q)
        full = rov.configuration(base=five.fk(q, "base_link"), arm=np.insert(arm, 5, 0.3))  # j6 at its held value
        for frame in ("arm_tool", "finger_c_link"):
            np.testing.assert_allclose(five.fk(q, frame).homogeneous, rov.fk(full, frame).homogeneous, atol=1e-12)
    with_propeller = uvms.load(IDIOMS, arm_joints=[*ARM, "thruster_0_joint"])
    assert with_propeller.n_arm == 8 and with_propeller.joint_classes["thruster_0_joint"].reason.startswith(
        "named in arm_joints (by the rule a propeller: uuv_simulator thruster plugin")
    assert uvms.load(IDIOMS, arm_joints=[]).n_arm == 0  # the vehicle alone


def test_a_mimic_of_a_frozen_joint_is_held_by_its_relation(rov, rng):
    robot = uvms.load(IDIOMS, arm_joints=ARM[:6])
    assert robot.mimic_joint_names == [] and robot.joint_classes["finger_c"].value == pytest.approx(0.1)
    assert robot.joint_classes["finger_c"].reason.endswith("which is frozen (frozen): q = -0.5 q(finger_a) + 0.1 "
                                                           "held at 0.1")
    q = robot.random_configuration(rng)
    full = rov.configuration(base=robot.fk(q, "base_link"), arm=[*robot.arm_configuration(q), 0.0])
    np.testing.assert_allclose(robot.fk(q, "finger_c_link").homogeneous, rov.fk(full, "finger_c_link").homogeneous,
                               atol=1e-12)


def test_arm_joints_that_cannot_be_commanded_are_refused_with_the_valid_ones():
    valid = "thruster_0_joint, thruster_1_joint, rov/pressure_joint, j1, j2, j3, j4, j5, j6, finger_a"
    with pytest.raises(NameNotFound) as caught:
        uvms.load(IDIOMS, arm_joints=["j1", "j7"])
    assert str(caught.value).endswith(f"arm_joints: unknown arm joint 'j7'; close names: {valid}")
    with pytest.raises(ModelCheckError,
                       match=r"'finger_b', which mimics 'finger_a': name 'finger_a' instead \(valid: "):
        uvms.load(IDIOMS, arm_joints=["finger_b"])
    with pytest.raises(ModelCheckError, match=re.escape("'anchor', which cannot move (limits "
                                                        f"[0.2, 0.2]); valid: {valid}")):
        uvms.load(IDIOMS, arm_joints=["anchor"])
    with pytest.raises(ModelCheckError, match="arm_joints must be a list of joint names, got 'j1'"):
        uvms.load(IDIOMS, arm_joints="j1")


def mimic_chain(first: str, second: str) -> str:
    """A three-joint arm whose j2 mimics ``first`` and j3 mimics ``second``."""
    links = "".join(f'<link name="l{i}"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" '
                    f'iyz="0"/></inertial></link>' for i in (1, 2, 3))
    joints = "".join(
        f'<joint name="j{i}" type="revolute"><parent link="{parent}"/><child link="l{i}"/><axis xyz="0 0 1"/>'
        f'<limit lower="-1" upper="1" effort="1" velocity="1"/>{mimic}</joint>'
        for i, parent, mimic in ((1, "base", ""), (2, "l1", f'<mimic joint="{first}"/>'),
                                 (3, "l2", f'<mimic joint="{second}" multiplier="2"/>')))
    return f'<robot name="chain"><link name="base"/>{links}{joints}</robot>'


def test_mimic_cycles_and_mimics_of_missing_joints_are_one_line_errors():
    assert uvms.load(mimic_chain("j1", "j2")).nq == 1
    with pytest.raises(ModelCheckError, match=r"mimic joints form a cycle \(j2 -> j3 -> j2\)"):
        uvms.load(mimic_chain("j3", "j2"))
    with pytest.raises(ModelCheckError, match="joint 'j2' mimics 'j9', which is not a joint of the model"):
        uvms.load(mimic_chain("j9", "j2"))
    with pytest.raises(ModelCheckError) as caught:
        uvms.load(mimic_chain("j3", "j2"))
    assert "\n" not in str(caught.value)
