"""Monte Carlo workspace: batched forward kinematics, sampling, volumes, `uvms workspace`."""

from __future__ import annotations

import json

import numpy as np
import pinocchio as pin
import pytest

from conftest import shipped
from test_fk_papers import xiang_eq6
from uvms.cli import main
from uvms.workspace import BatchKinematics, common_volume, monte_carlo, voxel_volume


def arm_vector(robot, batch, values):
    arm = np.zeros(robot.n_arm)
    names = robot.arm_joint_names
    for column, name in enumerate(batch.joint_names):
        arm[names.index(name)] = values[column]
    return arm


@pytest.mark.parametrize(("name", "frame"), [("xiang2019", "left_ee"), ("xiang2019", "right_ee"),
                                             ("bluerov2_alpha5", "alpha_push_rod_link"), ("amundsen2018", "ee")])
def test_batched_fk_equals_robot_fk(name, frame, rng):
    robot = shipped(name)
    batch = BatchKinematics(robot, frame)
    values = batch.sample(300, rng)
    base = pin.SE3(pin.rpy.rpyToMatrix(0.1, -0.2, 0.3), np.array([1.0, -2.0, 0.5]))
    rotations, positions = batch.poses(values, base)
    only_positions = batch.positions(values, base)
    for k in range(0, 300, 3):
        expected = robot.fk(robot.configuration(base=base, arm=arm_vector(robot, batch, values[k])), frame)
        assert np.allclose(positions[k], expected.translation, atol=1e-12)
        assert np.allclose(only_positions[k], expected.translation, atol=1e-12)
        assert np.allclose(rotations[k], expected.rotation, atol=1e-12)


def test_batched_fk_equals_xiang2019_eq7(rng):
    robot = shipped("xiang2019")
    batch = BatchKinematics(robot, "left_ee")
    values = batch.sample(5000, rng)
    positions = batch.positions(values)
    base = robot.fk(robot.neutral(), "left_base")
    relative = (positions - base.translation) @ base.rotation  # into D-H frame 0
    expected = np.array([xiang_eq6(theta).translation for theta in values])
    assert np.max(np.abs(relative - expected)) <= 1e-12


def test_samples_are_uniform_inside_the_limits(rng):
    batch = BatchKinematics(shipped("xiang2019"), "right_ee")
    values = batch.sample(20000, rng)
    assert np.all(values >= batch.lower) and np.all(values <= batch.upper)
    assert batch.joint_names == ["right_joint1", "right_joint2", "right_joint3", "right_joint4"]
    middle = 0.5 * (batch.lower + batch.upper)
    assert np.allclose(values.mean(axis=0), middle, atol=0.02 * (batch.upper - batch.lower).max())


def test_volume_estimate_converges():
    result = monte_carlo(shipped("xiang2019"), ["left_ee"], 640_000, seed=3, voxel=0.1)
    volumes = [volume for _, volume in result.convergence["left_ee"]]  # at 80k, 160k, 320k, 640k samples
    changes = np.diff(volumes) / volumes[-1]
    assert np.all(changes >= 0)  # more samples never empty a voxel
    assert np.all(np.diff(changes) < 0)  # each doubling adds less
    assert changes[-1] < 0.02  # the last doubling changes the estimate by less than 2 %


def test_voxel_volume_of_a_known_box():
    rng = np.random.default_rng(0)
    points = rng.uniform([0, 0, 0], [1.0, 0.5, 0.2], size=(200_000, 3))
    assert voxel_volume(points, 0.05) == pytest.approx(0.1, rel=1e-9)
    assert common_volume(points, points + [0.5, 0, 0], 0.05) == pytest.approx(0.05, rel=1e-9)


def test_cli_workspace_outputs(tmp_path, capsys):
    assert main(["workspace", "xiang2019", "--ee", "left_ee", "--ee", "right_ee", "-n", "5000",
                 "--out", str(tmp_path), "--quiet"]) == 0
    metrics = json.loads((tmp_path / "metrics.json").read_text())
    assert metrics["samples"] == 5000 and set(metrics["volume"]) == {"left_ee", "right_ee", "common"}
    assert metrics["volume"]["common"] < metrics["volume"]["left_ee"] and metrics["samples_per_second"] > 0
    points = np.load(tmp_path / "points.npz")
    assert points["q_left_ee"].shape == (5000, 4) and points["position_right_ee"].shape == (5000, 3)
    assert (tmp_path / "workspace.png").stat().st_size > 20_000
    assert main(["workspace", "xiang2019", "--ee", "nosuch", "-n", "10"]) == 2
