"""A ROS workspace written in uuv_simulator's idioms loads and runs as it is (tests/fixtures/uuv_ws).

The vehicle package includes the arm package by ``$(find)`` (found by walking up to the workspace's ``src``), uses
the other xacro namespace, mounts its thrusters on continuous propeller joints with point-mass links and plugins
without a thrust range, its sensors on zero-range joints, prints its added mass almost symmetric; the arm has a
zero-range ``anchor``, cylinder hydrodynamic models and a gripper whose mimics form a chain whose root comes last in
Pinocchio's order. Nothing in these files was edited for uvms.
"""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest

import uvms
from uvms.dynamics.thrusters.thrusters import allocation_matrix, thrusters_of
from uvms.errors import AddedMassSymmetrizedWarning, BaseGuessWarning, PointMassWarning

from conftest import ROOT

PACKAGE = ROOT / "tests" / "fixtures" / "uuv_ws" / "src" / "fixture_uuv_rov"
MODEL = PACKAGE / "urdf" / "rov.urdf.xacro"
#: The masses written in the files [kg]: vehicle, 8 thrusters, 4 sensors, the arm's links.
FILE_MASS = 1862.87 + 8 * 0.001 + 4 * 0.01 + (4 + 4 + 8 + 6 + 3 + 3 * 0.5)


@pytest.fixture(scope="module")
def robot():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return uvms.load(MODEL)


def test_the_joints_a_user_commands_and_the_rest_frozen(robot):
    kinds = {}
    for name, joint_class in robot.joint_classes.items():
        kinds.setdefault(joint_class.kind, []).append(name)
    assert robot.n_arm == 5 and robot.arm_joint_names == [
        "rov/shoulder_yaw", "rov/shoulder_pitch", "rov/elbow", "rov/wrist_roll", "rov/finger_b_joint"]
    assert len(kinds["propeller"]) == 8 and kinds["fixed by range"] == ["rov/anchor"]
    assert sorted(kinds["sensor"]) == ["rov/camera_joint", "rov/dvl_joint", "rov/imu_joint", "rov/pressure_joint"]
    assert sorted(kinds["mimic"]) == ["rov/finger_c_joint", "rov/jaw"]
    assert robot.ee_frames == ["rov/arm/end_effector"] and robot.total_mass == pytest.approx(FILE_MASS, abs=1e-9)


def test_the_mimic_chain_moves_the_fingers_as_the_file_says(robot):
    """The file: finger_b = -jaw, finger_c = 0.5 finger_b + 0.1 (about z, relative to their parents)."""
    data = robot.model.createData()

    def angle(frame: str, parent: str, q: np.ndarray) -> float:
        pin.framesForwardKinematics(robot.model, data, q)
        relative = (data.oMf[robot.model.getFrameId(parent)].rotation.T
                    @ data.oMf[robot.model.getFrameId(frame)].rotation)
        return float(np.arctan2(relative[1, 0], relative[0, 0]))

    for finger_b in (-0.7, -0.3, 0.0):
        q = robot.configuration(arm=[0.2, 0.5, 0.6, 0.3, finger_b])
        assert angle("rov/arm/finger_b", "rov/arm/wrist", q) == pytest.approx(finger_b, abs=1e-12)
        assert angle("rov/arm/finger_a", "rov/arm/wrist", q) == pytest.approx(-finger_b, abs=1e-12)  # the jaw
        assert angle("rov/arm/finger_c", "rov/arm/finger_b", q) == pytest.approx(0.5 * finger_b + 0.1, abs=1e-12)


def test_the_thrusters_are_the_plugins_completed_by_the_yaml(robot):
    thrusters = thrusters_of(robot)
    assert len(thrusters) == 8 and np.all(thrusters.upper == 1000.0) and np.all(thrusters.lower == -1000.0)
    assert np.all(thrusters.time_constants == 0.05)  # the plugins' FirstOrder dynamics
    column = allocation_matrix(robot, thrusters)[:, 4]  # thruster 4: yaw 45 deg at (-0.412125, 0.505415, 0.129)
    direction = np.array([np.cos(np.pi / 4), np.sin(np.pi / 4), 0.0])
    point = np.array([-0.412125, 0.505415, 0.129])
    np.testing.assert_allclose(column, np.concatenate([direction, np.cross(point, direction)]), atol=1e-6)


def test_the_intervention_runs_on_the_actuated_vehicle_with_default_gains(tmp_path):
    with pytest.warns(uvms.errors.UVMSWarning) as said:  # what uvms tells the user of a uuv_simulator model
        result = uvms.run_scenario(PACKAGE / "scenarios" / "intervention.toml", out=tmp_path / "run", progress=False)
    assert {type(w.message) for w in said} == {PointMassWarning, BaseGuessWarning, AddedMassSymmetrizedWarning}
    metrics = result.metrics
    assert metrics["verdict"]["ok"] and metrics["max_joint_limit_violation"] == 0.0
    assert metrics["max_position_error"] < 0.01  # measured 4.5 mm along the 0.2 m line in a 0.3 m/s current
    assert metrics["max_vehicle_tilt"] < 0.005 and metrics["vehicle_position_error"] < 0.01
    assert 0.02 < metrics["max_thrust_ratio"] < 0.3  # the thrusters work against the current, far from saturation
