"""ROS 2 files out (uvms.scenario.bags.writer): a run written as a rosbag2 (MCAP) with rosbags, read back with
rosbags."""

from __future__ import annotations

import dataclasses
import sys
import types
from collections import defaultdict
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from rosbags.interfaces import QosDurability
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore

import uvms
from uvms.errors import BagExportError, RunFolderError
from uvms.scenario import run_scenario
from uvms.scenario.bags.writer import write_bag
from uvms.sim import PlantSeries, simulate
from uvms.tasks.frame import FrameTask

from conftest import FIXED_ARM, SCENARIOS, shipped

START = 1_700_000_000_123_456_789  # [ns]


def read_bag(path: Path) -> tuple[dict, dict[str, list]]:
    """The connections by topic and the (log time [ns], message) pairs by topic."""
    typestore = get_typestore(Stores.ROS2_HUMBLE)
    messages: dict[str, list] = defaultdict(list)
    with Reader(path) as reader:
        connections = {connection.topic: connection for connection in reader.connections}
        for connection, timestamp, raw in reader.messages():
            messages[connection.topic].append((timestamp, typestore.deserialize_cdr(raw, connection.msgtype)))
    return connections, messages


def stamp_ns(header) -> int:
    return header.stamp.sec * 1_000_000_000 + header.stamp.nanosec


def se3(translation, rotation) -> pin.SE3:
    """A pose from ROS vector and quaternion fields (x, y, z, w)."""
    quaternion = pin.Quaternion(rotation.w, rotation.x, rotation.y, rotation.z)
    return pin.SE3(quaternion.toRotationMatrix(), np.array([translation.x, translation.y, translation.z]))


def world_pose(frame: str, tf_static, tf_row) -> pin.SE3:
    """The pose of ``frame`` in ``odom``, composed along the tf tree of one sample."""
    parents = {t.child_frame_id: (t.header.frame_id, se3(t.transform.translation, t.transform.rotation))
               for t in [*tf_static.transforms, *tf_row.transforms]}
    pose = pin.SE3.Identity()
    while frame != "odom":
        frame, relative = parents[frame]
        pose = relative * pose
    return pose


def constant_rate_run(robot: uvms.Robot, rate: np.ndarray, q0: np.ndarray, goal: pin.SE3):
    """A short kinematic run at a constant velocity v (nv,), desired pose ``goal`` throughout."""
    info = types.SimpleNamespace(sigma_min=1.0, damping=0.0, limits_active=())
    return simulate(robot, uvms.control.OpenLoop(velocity=rate, info=info), q0, duration=1.0, dt=0.05,
                    task=FrameTask(robot), desired=lambda t: goal)


@pytest.fixture(scope="module")
def floating_bag(tmp_path_factory):
    robot = shipped("bluerov2_alpha5")
    q0 = robot.configuration(base=[1.0, 2.0, -3.0, 0.1, 0.2, 0.3], arm=[0.5, 1.0, 0.5, 0.3, 0.01])
    goal = pin.SE3(pin.rpy.rpyToMatrix(0.3, -0.2, 1.1), np.array([1.5, 2.0, -2.5]))
    rate = np.array([0.2, -0.1, 0.05, 0.1, -0.05, 0.3, 0.2, -0.1, 0.3, 0.1, 0.2])
    result = constant_rate_run(robot, rate, q0, goal)
    path = tmp_path_factory.mktemp("floating") / "bag"
    summary = write_bag(path, robot, result, start_time_ns=START)
    return robot, result, goal, summary, *read_bag(path)


def test_a_floating_run_has_every_topic_with_one_message_per_sample(floating_bag):
    robot, result, _, summary, connections, messages = floating_bag
    n = len(result.t)
    expected = {"/robot_description": ("std_msgs/msg/String", 1), "/tf_static": ("tf2_msgs/msg/TFMessage", 1),
                "/tf": ("tf2_msgs/msg/TFMessage", n), "/joint_states": ("sensor_msgs/msg/JointState", n),
                "/odom": ("nav_msgs/msg/Odometry", n), "/ee/desired_pose": ("geometry_msgs/msg/PoseStamped", n)}
    assert {topic: (c.msgtype, len(messages[topic])) for topic, c in connections.items()} == expected
    assert summary.topics == {topic: count for topic, (_, count) in expected.items()}
    assert summary.skipped == {}
    assert "/odom (nav_msgs/msg/Odometry): 21" in summary.describe()
    for topic in ("/tf_static", "/robot_description"):  # latched, so RViz's transient-local subscribers get them
        assert connections[topic].ext.offered_qos_profiles[0].durability == QosDurability.TRANSIENT_LOCAL
    assert messages["/robot_description"][0][1].data == robot.urdf
    assert sorted(path.name for path in summary.path.iterdir()) == [".uvms-run.json", "bag.mcap", "metadata.yaml"]


def test_stamps_are_the_start_time_plus_t(floating_bag):
    _, result, _, _, _, messages = floating_bag
    expected = START + np.round(result.t * 1e9).astype(np.int64)
    for topic in ("/tf", "/joint_states", "/odom", "/ee/desired_pose"):
        assert [time for time, _ in messages[topic]] == expected.tolist()
        headers = [message.transforms[0].header if topic == "/tf" else message.header for _, message in messages[topic]]
        assert [stamp_ns(header) for header in headers] == expected.tolist()
    assert messages["/robot_description"][0][0] == expected[0] == START


def test_joint_states_are_the_arm_part_of_q_and_v(floating_bag):
    robot, result, _, _, _, messages = floating_bag
    for k, (_, state) in enumerate(messages["/joint_states"]):
        assert state.name == robot.arm_joint_names
        np.testing.assert_allclose(state.position, result.q[k, 7:], rtol=0, atol=1e-12)
        np.testing.assert_allclose(state.velocity, result.v[k, 6:], rtol=0, atol=1e-12)
        assert len(state.effort) == 0  # a kinematic run has no torques


def test_odometry_is_the_base_pose_and_the_body_twist(floating_bag):
    robot, result, _, _, _, messages = floating_bag
    for k, (_, odometry) in enumerate(messages["/odom"]):
        assert (odometry.header.frame_id, odometry.child_frame_id) == ("odom", "base_link")
        pose = se3(odometry.pose.pose.position, odometry.pose.pose.orientation)
        assert pose.isApprox(robot.base_pose(result.q[k]), 1e-12)
        twist = odometry.twist.twist
        body = [twist.linear.x, twist.linear.y, twist.linear.z, twist.angular.x, twist.angular.y, twist.angular.z]
        np.testing.assert_allclose(body, result.v[k, :6], rtol=0, atol=1e-12)


def test_tf_composes_to_the_forward_kinematics_of_every_link(floating_bag):
    robot, result, _, _, _, messages = floating_bag
    tf_static = messages["/tf_static"][0][1]
    assert {t.header.frame_id for t in tf_static.transforms} >= {"odom", "base_link"}  # world link, arm mount
    for k, (_, tf_row) in enumerate(messages["/tf"]):
        first = tf_row.transforms[0]
        assert (first.header.frame_id, first.child_frame_id) == ("odom", "base_link")
        assert all(stamp_ns(t.header) == START + round(result.t[k] * 1e9) for t in tf_row.transforms)
        for frame in ("ee", "alpha_push_rod_link", "base_link"):
            np.testing.assert_allclose(world_pose(frame, tf_static, tf_row).homogeneous,
                                       robot.fk(result.q[k], frame).homogeneous, rtol=0, atol=1e-9)


def test_the_desired_pose_is_the_runs(floating_bag):
    _, _, goal, _, _, messages = floating_bag
    for _, desired in messages["/ee/desired_pose"]:
        assert desired.header.frame_id == "odom"
        assert se3(desired.pose.position, desired.pose.orientation).isApprox(goal, 1e-12)


def test_a_planar_scenario_run_reads_back_as_its_trajectory_npz(tmp_path):
    """hoang2011 (planar base), shortened: the bag of the run folder against the run's own trajectory.npz."""
    out = tmp_path / "run"
    ran = run_scenario(SCENARIOS / "hoang2011_w1.toml", out=out, progress=False,
              overrides=["outputs.figures=false", "simulation.duration=1.0", "simulation.dt=0.1"])
    robot, simulation = ran.setup.robot, ran.simulation
    summary = write_bag(out / "bag", robot, simulation, desired_frame=ran.setup.task.frame, lock=False)
    saved = np.load(out / "trajectory.npz")
    n = len(saved["t"])
    assert summary.topics == {"/robot_description": 1, "/tf_static": 1, "/tf": n, "/joint_states": n, "/odom": n,
                              "/ee/desired_pose": n}
    _, messages = read_bag(out / "bag")
    assert [time for time, _ in messages["/odom"]] == np.round(saved["t"] * 1e9).astype(np.int64).tolist()
    tf_static = messages["/tf_static"][0][1]
    for k in range(n):
        q, v = saved["q"][k], saved["v"][k]
        state = messages["/joint_states"][k][1]
        assert state.name == ["q1", "q2", "q3"]
        np.testing.assert_allclose(state.position, q[4:], rtol=0, atol=1e-12)
        odometry = messages["/odom"][k][1]
        pose = odometry.pose.pose
        assert pose.position.z == 0.0 and pose.orientation.x == 0.0 and pose.orientation.y == 0.0  # yaw only
        assert se3(pose.position, pose.orientation).isApprox(robot.base_pose(q), 1e-12)
        twist = odometry.twist.twist
        np.testing.assert_allclose([twist.linear.x, twist.linear.y, twist.linear.z, twist.angular.x,
                                    twist.angular.y, twist.angular.z], [v[0], v[1], 0, 0, 0, v[2]], rtol=0, atol=1e-12)
        np.testing.assert_allclose(world_pose("ee", tf_static, messages["/tf"][k][1]).homogeneous,
                                   robot.fk(q, "ee").homogeneous, rtol=0, atol=1e-9)
        desired = messages["/ee/desired_pose"][k][1].pose
        np.testing.assert_allclose([desired.position.x, desired.position.y, desired.position.z],
                                   saved["desired_position"][k], rtol=0, atol=1e-12)
        rotation = se3(desired.position, desired.orientation).rotation
        np.testing.assert_allclose(rotation, pin.rpy.rpyToMatrix(*saved["desired_rpy"][k]), rtol=0, atol=1e-12)
    assert messages["/robot_description"][0][1].data == robot.urdf


def test_a_robot_without_urdf_or_vehicle_says_what_it_skipped(tmp_path):
    composed = uvms.Robot(shipped("hoang2011").model)  # as mount_arm builds it: no URDF text
    result = constant_rate_run(composed, np.full(composed.nv, 0.1), composed.neutral(), pin.SE3.Identity())
    summary = write_bag(tmp_path / "composed", composed, result)
    assert "/robot_description" not in summary.topics and "no URDF" in summary.skipped["/robot_description"]
    fixed = uvms.load(FIXED_ARM)
    result = constant_rate_run(fixed, np.array([0.5]), fixed.neutral(), pin.SE3.Identity())
    result = dataclasses.replace(result, desired_position=None, desired_rpy=None)
    summary = write_bag(tmp_path / "fixed", fixed, result)
    assert set(summary.skipped) == {"/odom", "/tip/desired_pose"}
    assert set(summary.topics) == {"/robot_description", "/tf_static", "/tf", "/joint_states"}
    _, messages = read_bag(tmp_path / "fixed")
    static = messages["/tf_static"][0][1].transforms
    assert [(t.header.frame_id, t.child_frame_id) for t in static] == [("odom", "base")]
    moving = messages["/tf"][-1][1].transforms
    assert [(t.header.frame_id, t.child_frame_id) for t in moving] == [("base", "tip")]
    assert moving[0].transform.rotation.z == pytest.approx(np.sin(0.25))  # 0.5 rad after 1 s at 0.5 rad/s


def test_given_poses_torques_and_a_position_only_desired(tmp_path, floating_bag):
    """desired= as (N, 4, 4) poses; a plant run's torques as efforts; a desired position alone as a point."""
    robot, result, *_ = floating_bag
    n = len(result.t)
    poses = np.array([pin.SE3(np.eye(3), np.array([0.0, 0.0, -k])).homogeneous for k in range(n)])
    plant_like = dataclasses.replace(result, plant=PlantSeries(
        command=np.zeros((n, 5)), joint_torque=np.arange(n * 5.0).reshape(n, 5), kinetic_energy=np.zeros(n),
        potential_energy=np.zeros(n), momentum=np.zeros((n, 6))))
    write_bag(tmp_path / "poses", robot, plant_like, desired=poses, desired_frame="alpha_jaw_link")
    _, messages = read_bag(tmp_path / "poses")
    heights = [message.pose.position.z for _, message in messages["/alpha_jaw_link/desired_pose"]]
    assert heights == [-k for k in range(n)]
    np.testing.assert_array_equal([state.effort for _, state in messages["/joint_states"]],
                                  plant_like.plant.joint_torque)
    position_only = dataclasses.replace(result, desired_rpy=None)
    summary = write_bag(tmp_path / "points", robot, position_only)
    assert summary.types["/ee/desired_position"] == "geometry_msgs/msg/PointStamped"
    _, messages = read_bag(tmp_path / "points")
    point = messages["/ee/desired_position"][3][1].point
    np.testing.assert_array_equal([point.x, point.y, point.z], result.desired_position[3])


def test_a_bag_is_replaced_whole_and_a_foreign_folder_is_kept(tmp_path, floating_bag):
    robot, result, *_ = floating_bag
    path = tmp_path / "bag"
    write_bag(path, robot, result)
    write_bag(path, robot, result, start_time_ns=5)
    _, messages = read_bag(path)
    assert messages["/odom"][0][0] == 5
    assert sorted(p.name for p in tmp_path.iterdir()) == [".bag.uvms-lock", "bag"]  # no temporary left
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("keep")
    with pytest.raises(RunFolderError, match="not written by uvms"):
        write_bag(tmp_path / "mine", robot, result)
    assert (tmp_path / "mine" / "notes.txt").read_text() == "keep"


def test_bad_input_is_refused_before_anything_is_written(tmp_path, floating_bag):
    robot, result, *_ = floating_bag
    with pytest.raises(BagExportError, match="start_time_ns must be an integer >= 0"):
        write_bag(tmp_path / "bag", robot, result, start_time_ns=-1)
    with pytest.raises(BagExportError, match=r"the run's q must have shape \(21, 7\), got \(21, 12\)"):
        write_bag(tmp_path / "bag", shipped("hoang2011"), result)
    with pytest.raises(BagExportError, match="desired holds 2 poses; the run has 21 samples"):
        write_bag(tmp_path / "bag", robot, result, desired=[pin.SE3.Identity()] * 2)
    with pytest.raises(BagExportError, match="the run's v has non-finite entries"):
        write_bag(tmp_path / "bag", robot, dataclasses.replace(result, v=np.full_like(result.v, np.nan)))
    with pytest.raises(BagExportError, match="the run's t must be .*non-decreasing"):
        write_bag(tmp_path / "bag", robot, dataclasses.replace(result, t=result.t[::-1]))
    with pytest.raises(uvms.errors.FrameNotFound):
        write_bag(tmp_path / "bag", robot, result, desired_frame="hand")
    assert not (tmp_path / "bag").exists()


def test_thruster_names_that_share_a_topic_are_refused(tmp_path, floating_bag):
    """thruster_1 and thruster.1 both became /thrusters/thruster_1/thrust: two thrusters interleaved on one topic."""
    robot, result, *_ = floating_bag
    actuation = types.SimpleNamespace(thrusts=np.zeros((21, 3)), body_wrench=np.zeros((21, 6)))
    with pytest.raises(BagExportError, match="thrusters 'thruster_1' and 'thruster.1' both become the topic token "
                                             "'thruster_1'"):
        write_bag(tmp_path / "bag", robot, dataclasses.replace(result, actuation=actuation),
                  thrusters=["thruster_1", "thruster_2", "thruster.1"])
    assert not (tmp_path / "bag").exists()


def test_without_rosbags_the_error_gives_the_install_command(monkeypatch, tmp_path, floating_bag):
    robot, result, *_ = floating_bag
    monkeypatch.setitem(sys.modules, "rosbags.rosbag2", None)  # import fails as if not installed
    with pytest.raises(BagExportError, match=r"pip install 'uvms\[ros\]'"):
        write_bag(tmp_path / "bag", robot, result)


def test_uvms_run_bag_writes_the_run_beside_its_files(tmp_path):
    """`uvms run S --bag`: OUT/bag holds one message per sample of trajectory.npz, and the terminal says so."""
    import json
    import subprocess

    out = tmp_path / "run"
    command = [sys.executable, "-m", "uvms.cli", "run", "hoang2011_w1", "--bag", "--out", str(out),
               "--set", "outputs.figures=false", "--set", "trajectory.duration=10"]
    done = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    series = np.load(out / "trajectory.npz")
    samples = len(series["t"])  # 501: 10 s at dt = 0.02 s
    assert samples == 501
    assert f"bag         {out / 'bag'}/" in done.stdout and f"/joint_states {samples}," in done.stdout
    connections, messages = read_bag(out / "bag")
    assert {"/joint_states", "/odom", "/tf", "/ee/desired_pose", "/robot_description"} <= set(connections)
    assert len(messages["/joint_states"]) == len(messages["/odom"]) == samples
    positions = np.array([message.position for _, message in messages["/joint_states"]])
    assert np.abs(positions - series["q"][:, 4:]).max() <= 1e-12  # planar q = [x, y, cos, sin, q1..q3]
    assert json.loads((out / "metrics.json").read_text())["bag"]["topics"]["/joint_states"] == samples
