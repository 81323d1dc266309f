"""Dual-arm control of xiang2019 (uvms.control.sequence, uvms.tasks.relative): distance and joint tasks, phase plans,
the gripping scenario."""

from __future__ import annotations

import json

import numpy as np
import pinocchio as pin
import pytest
from PIL import Image

from uvms import UVMSError
from uvms.control.sequence import Phase, PhasePlan, SequenceController
from uvms.robot.configuration import Configuration
from uvms.scenario import ScenarioError, read_scenario, run_scenario
from uvms.scenario.build import build
from uvms.solvers import CLIKSolver, PrioritySolver
from uvms.solvers.base import SolverFactory
from uvms.tasks import DistanceTask, FrameTask, JointTask

from conftest import SCENARIOS, shipped

GRIP = SCENARIOS / "xiang2019_grip.toml"
ARMS = [-1.57, 0.6, -0.5, -0.4, 0.0, -1.57, -0.6, 0.5, 0.4, 0.0]  # mirror postures, claws closed


def xiang_q0() -> np.ndarray:
    return shipped("xiang2019").configuration(arm=np.array(ARMS))


def test_distance_task_jacobian_is_the_derivative(rng):
    robot = shipped("xiang2019")
    task = DistanceTask(robot, "left_ee", "right_ee", distance=0.3)
    for _ in range(5):
        q, v = robot.random_configuration(rng), rng.normal(size=robot.nv)
        h = 1e-6
        plus, minus = (task.current(Configuration(robot, pin.integrate(robot.model, q, s * h * v))) for s in (1, -1))
        rate = (plus - minus) / (2 * h)  # states share the robot's data: read each before the next
        assert task.jacobian(Configuration(robot, q)) @ v == pytest.approx([rate], abs=1e-7)
    with pytest.raises(UVMSError, match="two different frames"):
        DistanceTask(robot, "left_ee", "left_ee")
    with pytest.raises(UVMSError, match=">= 0"):
        task.set_target(-0.1)


def test_joint_task_rows_and_limits():
    robot = shipped("xiang2019")
    task = JointTask(robot, {"left_claw": 0.5, "right_claw": 0.2})
    state = Configuration(robot, xiang_q0())
    assert task.error(state) == pytest.approx([0.5, 0.2])
    jacobian = task.jacobian(state)
    assert jacobian.shape == (2, robot.nv) and jacobian.sum() == 2.0
    assert jacobian[0, robot.joints[robot.joint_id("left_claw") - 1].idx_v] == 1.0
    with pytest.raises(UVMSError, match="outside the limits"):
        task.set_target({"left_claw": 1.5})  # the claw opens to 0.8 rad
    with pytest.raises(UVMSError, match="not in this task"):
        task.set_target({"left_joint1": 0.0})


def test_both_claws_reach_constant_targets_to_1e10():
    """Stacked CLIK with both claw positions, the claw distance and the jaws: converges to 1e-10, vehicle at rest."""
    robot = shipped("xiang2019")
    q = xiang_q0()
    left, right = robot.fk(q, "left_ee").translation, robot.fk(q, "right_ee").translation
    shift = np.array([0.05, 0.0, 0.1])
    tasks = [FrameTask(robot, "left_ee", axes=("x", "y", "z"), target=pin.SE3(np.eye(3), left + shift + [0, 0.1, 0])),
             FrameTask(robot, "right_ee", axes=("x", "y", "z"), target=pin.SE3(np.eye(3), right + shift - [0, 0.1, 0])),
             JointTask(robot, {"left_claw": 0.6, "right_claw": 0.6})]
    plan = PhasePlan(robot, q, ["left_ee", "right_ee"], [Phase("hold", 1.0)])
    controller = SequenceController(robot, plan, SolverFactory(CLIKSolver, robot))
    solver = CLIKSolver(robot, [controller.vehicle_task, *tasks], gain=1.0)
    for _ in range(60):
        q = pin.integrate(robot.model, q, solver.velocity(Configuration(robot, q)).v * 0.5)
    state = Configuration(robot, q)
    assert max(np.abs(task.error(state)).max() for task in tasks) <= 1e-10
    assert np.abs(robot.base_pose(q).translation).max() <= 1e-12


def test_phase_plan_spreads_the_claws_about_their_midpoint():
    robot = shipped("xiang2019")
    q0 = xiang_q0()
    plan = PhasePlan(robot, q0, ["left_ee", "right_ee"], [
        Phase("open", 2.0, offsets={"left_ee": [0, 0.1, 0], "right_ee": [0, -0.1, 0.0]}, joints={"left_claw": 0.8}),
        Phase("grip", 2.0, distance=0.3)])
    start = {f: robot.fk(q0, f).translation for f in plan.frames}
    middle = 0.5 * (start["left_ee"] + start["right_ee"])
    end = plan(4.0)
    assert np.linalg.norm(end.positions["right_ee"][0] - end.positions["left_ee"][0]) == pytest.approx(0.3, abs=1e-15)
    assert 0.5 * (end.positions["right_ee"][0] + end.positions["left_ee"][0]) == pytest.approx(middle, abs=1e-15)
    assert plan(1.0).distance is None and plan(3.0).distance is not None  # only the grip phase drives it
    assert plan(2.0).joints["left_claw"][0] == pytest.approx(0.8) and plan(1.0).joints["left_claw"][1] > 0
    assert np.abs(plan(2.0).positions["left_ee"][1]).max() == 0.0  # rest at the phase boundary (quintic law)
    with pytest.raises(UVMSError, match="not task frames"):
        PhasePlan(robot, q0, ["left_ee", "right_ee"], [Phase("bad", 1.0, offsets={"left_claw_link": [0, 0, 0]})])
    with pytest.raises(UVMSError, match="left_claw"):
        PhasePlan(robot, q0, ["left_ee"], [Phase("bad", 1.0, joints={"left_clawz": 0.1})])


def test_distance_has_priority_over_inconsistent_claw_targets():
    robot = shipped("xiang2019")
    q = xiang_q0()
    plan = PhasePlan(robot, q, ["left_ee", "right_ee"], [Phase("grip", 1.0, distance=0.3)])
    controller = SequenceController(robot, plan, SolverFactory(PrioritySolver, robot, {"priority": "classic"}))
    controller.set_targets(1.0)
    target = controller.frame_tasks[0].target
    controller.frame_tasks[0].set_target(pin.SE3(np.eye(3), target.translation + [0, 0.05, 0]))
    solver = PrioritySolver(robot, controller.levels(with_distance=True), priority="classic")
    for _ in range(80):
        q = pin.integrate(robot.model, q, solver.velocity(Configuration(robot, q)).v * 0.5)
    state = Configuration(robot, q)
    assert abs(controller.distance_task.error(state)[0]) <= 1e-10  # the relative task wins ...
    assert np.linalg.norm(controller.frame_tasks[0].error(state)) > 1e-3  # ... over the inconsistent target


@pytest.fixture(scope="module")
def grip_run(tmp_path_factory):
    return run_scenario(GRIP, out=tmp_path_factory.mktemp("grip"), progress=False)


def test_grip_scenario_reaches_every_phase_target(grip_run):
    metrics = grip_run.metrics
    assert set(metrics["phase_end_position_error"]) == {"open", "lower", "grip"}
    assert max(metrics["phase_end_position_error"].values()) <= 1e-10
    assert metrics["max_frame_position_error"] <= 1e-9  # tracked all along, both claws
    assert metrics["final_distance"] == pytest.approx(0.45, abs=1e-10)
    assert metrics["final_joints"] == pytest.approx({"left_claw": 0.25, "right_claw": 0.25}, abs=1e-9)
    assert metrics["vehicle_travel"] <= 1e-12 and metrics["max_joint_limit_violation"] <= 1e-9
    saved = json.loads((grip_run.files[-1]).read_text())
    assert saved["final_distance"] == metrics["final_distance"]


def test_grip_scenario_writes_snapshots_and_an_animation(grip_run):
    names = {path.name for path in grip_run.files}
    assert {"snapshots.png", "frames.png", "grip.gif", "joints.png"} <= names
    folder = grip_run.files[0].parent
    with Image.open(folder / "grip.gif") as gif:
        assert gif.n_frames == 56  # 11 s at 5 frames per second, both ends included


def test_unknown_phase_key_lists_the_valid_ones(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(GRIP.read_text().replace("[[phases]]\nname = \"lower\"", "[[phases]]\noffset = "
                                                                             "{}\nname = \"lower\""))
    with pytest.raises(ScenarioError, match=r"phases\[1\].offset.*valid in \[phases\[1\]\]: name, duration, offsets"):
        read_scenario(path)


@pytest.mark.parametrize("override, message", [
    ("solver.method=kinematic_constraint", "sequence scenario needs solver.method"),
    ("task.frames=['left_ee', 'nose']", "nose"),
])
def test_bad_sequence_scenarios(override, message):
    with pytest.raises(UVMSError, match=message):
        build(read_scenario(GRIP, [override]))


def test_sequence_without_phases_needs_a_trajectory(tmp_path):
    text = GRIP.read_text().split("[[phases]]")[0]
    path = tmp_path / "no_phases.toml"
    path.write_text(text + '\n[simulation]\ndt = 0.1\n' if "[simulation]" not in text else text)
    with pytest.raises(ScenarioError, match="missing section"):
        read_scenario(path)
