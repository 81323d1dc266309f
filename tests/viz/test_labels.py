"""Labels that follow the model and the run (uvms.viz.labels): joint units from Pinocchio's joint types, FLU names
of the vehicle's velocities, full names of the solver methods, titles wrapped to the figure."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from uvms.solvers import SOLVERS
from uvms.viz.labels import (
    METHOD_NAMES,
    TITLE_CHARACTERS_PER_INCH,
    arm_joint_labels,
    figure_title,
    joint_unit,
    method_name,
)

from conftest import shipped


def test_prismatic_joints_are_metres_and_every_other_joint_radians():
    axis = np.array([0.0, 0.6, 0.8])
    prismatic = [pin.JointModelPX(), pin.JointModelPY(), pin.JointModelPZ(), pin.JointModelPrismaticUnaligned(axis)]
    revolute = [pin.JointModelRX(), pin.JointModelRZ(), pin.JointModelRUBZ(), pin.JointModelRevoluteUnaligned(axis)]
    assert [joint_unit(joint.shortname()) for joint in prismatic] == ["m"] * 4
    assert [joint_unit(joint.shortname()) for joint in revolute] == ["rad"] * 4
    robot = shipped("bluerov2_alpha5")
    assert arm_joint_labels(robot)[robot.arm_joint_names.index("alpha_axis_a")] == "alpha_axis_a [m]"
    assert arm_joint_labels(robot, per_second=True)[0] == f"{robot.arm_joint_names[0]} [rad/s]"
    assert "alpha_axis_a [m/s]" in arm_joint_labels(robot, per_second=True)


def test_vehicle_velocities_are_named_by_their_flu_axis():
    assert shipped("hoang2011").base.velocity_labels == ("vx [m/s]", "vy [m/s]", "ωz [rad/s]")
    assert shipped("bluerov2_alpha5").base.velocity_labels == (
        "vx [m/s]", "vy [m/s]", "vz [m/s]", "ωx [rad/s]", "ωy [rad/s]", "ωz [rad/s]")
    for base in (shipped("hoang2011").base, shipped("bluerov2_alpha5").base):  # the labels name the twist's entries
        assert [label.split()[0].replace("ω", "w") for label in base.velocity_labels] == list(base.velocity_names)


def test_every_solver_method_has_a_full_name():
    assert set(METHOD_NAMES) == set(SOLVERS)  # a new method gets its name here
    assert method_name("set_based") == "set-based task priority (iCAT)"
    assert method_name("hqp") == "QP hierarchy"
    assert method_name("clik (monitored)") == "clik (monitored)"  # any other label as it is


def test_a_long_title_is_wrapped_to_the_figure_and_keeps_its_line_breaks():
    text = "bluerov2_alpha5_intervention: inequality objectives\n(dotted: valid set, grey: activation band, shaded)"
    wrapped = figure_title(text, 4.0)
    lines = wrapped.split("\n")
    assert len(lines) >= 3 and all(len(line) <= 4.0 * TITLE_CHARACTERS_PER_INCH for line in lines)
    assert wrapped.replace("\n", " ") == text.replace("\n", " ")
    assert figure_title(text, 20.0) == text
