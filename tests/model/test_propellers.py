"""Propeller joints by structure (uvms.model.propellers): a continuous joint to a massless or tiny leaf link named like
a propeller, with no plugin saying so; the RDML blue package at its default args (tests/fixtures/gz/
bluerov2_heavy_sim.urdf without its <gazebo> blocks) has no arm joint and a floating base."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import pytest

import uvms
from uvms.cli.info import describe

from conftest import ROOT

BLUE = ROOT / "tests" / "fixtures" / "gz" / "bluerov2_heavy_sim.urdf"


def blue_default_args(folder) -> str:
    """blue's description at its default args (use_sim false): no <gazebo> block, no plugin."""
    tree = ET.parse(BLUE)
    for element in tree.getroot().findall("gazebo"):
        tree.getroot().remove(element)
    path = folder / "bluerov2_heavy.urdf"
    tree.write(path)
    return path


def test_blue_at_its_default_args_has_eight_propellers_and_no_arm_joint(tmp_path):
    with pytest.warns(uvms.errors.BaseGuessWarning, match="'base_footprint' and the links fixed to it carry 13 kg "
                                                          "and 8 propeller joint"):
        robot = uvms.load(blue_default_args(tmp_path))
    assert robot.base_type == "floating" and robot.n_arm == 0 and robot.nv == 6
    assert [(name, c.kind) for name, c in robot.joint_classes.items()] == [
        (f"thruster{i}_joint", "propeller") for i in range(1, 9)]
    reason = robot.joint_classes["thruster3_joint"].reason
    assert reason == ("continuous joint to the leaf link 'thruster3' named like a propeller (thruster), 0.002 kg (at "
                      "most 1% of the model's 13.016 kg); no thruster plugin names it; held at 0")
    assert robot.ee_frames == ["base_footprint"]
    text = describe(robot)
    assert "propellers (8): carry a thruster; frozen" in text and "arm joints" not in text
    assert "thrusters   none (no thruster plugin of uuv_simulator, Gazebo Sim or HippoCampus" in text


ROOT_LINK = ('<link name="world"/><joint name="float" type="floating"><parent link="world"/><child link="hull"/>'
             '</joint><link name="hull"><inertial><mass value="20"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" '
             'izz="1"/></inertial></link>')


def spinner(name: str, link: str, mass: float | None, kind: str = "continuous", below: str = "") -> str:
    inertial = "" if mass is None else (f'<inertial><mass value="{mass}"/><inertia ixx="1e-6" ixy="0" ixz="0" '
                                        f'iyy="1e-6" iyz="0" izz="1e-6"/></inertial>')
    limit = '<limit lower="-1" upper="1" effort="1" velocity="1"/>' if kind == "revolute" else ""
    return (f'<link name="{link}">{inertial}</link><joint name="{name}" type="{kind}"><parent link="hull"/>'
            f'<child link="{link}"/><axis xyz="1 0 0"/>{limit}</joint>{below}')


@pytest.mark.parametrize("joint, expected", [
    (spinner("aft_joint", "aft_prop", None), "propeller"),                # massless, named 'prop'
    (spinner("j", "stern_propeller_link", 0.19), "propeller"),            # 0.19 kg <= 1 % of 20.19 kg
    (spinner("thruster_2_joint", "t2", 0.001), "propeller"),              # the joint's name says it
    (spinner("j", "prop", 0.5), "arm"),                                   # too heavy for a propeller
    (spinner("j", "prop", None, "revolute"), "arm"),                      # a propeller spins without limits
    (spinner("j", "wheel", None), "arm"),                                 # not named like a propeller
    (spinner("j", "prop", None, below='<link name="tip"/><joint name="k" type="revolute"><parent link="prop"/>'
                                      '<child link="tip"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" '
                                      'velocity="1"/></joint>'), "arm"),  # not a leaf: an arm goes on below it
])
def test_only_a_spinning_tiny_leaf_named_like_a_propeller_is_one(joint, expected):
    robot = uvms.load(f'<robot name="r">{ROOT_LINK}{joint}</robot>')
    assert robot.joint_classes[next(iter(robot.joint_classes))].kind == expected
