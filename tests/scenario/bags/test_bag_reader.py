"""A ROS 2 bag read back for identification (uvms.scenario.bags.reader): what write_bag wrote, and bad bags."""

from __future__ import annotations

import functools
import shutil

import numpy as np
import pinocchio as pin
import pytest

from uvms.dynamics.thrusters.thrusters import thrusters_of
from uvms.errors import IdentificationError
from uvms.scenario.bags.reader import read_bag
from uvms.scenario.bags.writer import write_bag
from uvms.scenario.excitation import excitation_run, log_of_run, multisine

from conftest import shipped


@functools.lru_cache(maxsize=None)
def short_run():
    """3 s of the BlueROV2 + Alpha 5 under a multi-sine, the arm moving (run, log)."""
    robot = shipped("bluerov2_alpha5")
    q0 = pin.neutral(robot.model)
    q0[7:12] = [3.0, 1.8, 1.8, 1.0, 0.0]
    run, _ = excitation_run(robot, multisine(np.array([20.0, 20.0, 30.0, 0.6, 0.6, 1.5])), q0, 3.0, 0.05,
                            arm_amplitudes=np.array([0.3, 0.3, 0.3, 0.3, 0.0]))
    return run, log_of_run(robot, run)


@pytest.fixture
def bag(tmp_path):
    robot = shipped("bluerov2_alpha5")
    run, _ = short_run()
    write_bag(tmp_path / "bag", robot, run, thrusters=thrusters_of(robot).names)
    return tmp_path / "bag"


def test_the_bag_gives_back_the_runs_log(bag):
    _, expected = short_run()
    for path in (bag, next(bag.glob("*.mcap"))):  # the folder, or its storage file
        log = read_bag(path)
        assert log.joint_names == expected.joint_names and len(log.t) == len(expected.t) == 61
        np.testing.assert_allclose(log.t, expected.t, atol=1e-9)
        for name in ("position", "quaternion", "twist", "wrench", "joint_position", "joint_velocity"):
            np.testing.assert_allclose(getattr(log, name), getattr(expected, name), atol=1e-12, err_msg=name)


def test_a_missing_topic_is_named_with_the_topics_there(bag):
    with pytest.raises(IdentificationError, match=r"no wrench topic '/thrust_wrench' \(its topics: .*/body_wrench"):
        read_bag(bag, wrench_topic="/thrust_wrench")


def test_a_topic_of_the_wrong_type_is_refused(bag):
    with pytest.raises(IdentificationError, match="topic '/joint_states' holds sensor_msgs/msg/JointState; the "
                                                  "odometry must be nav_msgs/msg/Odometry"):
        read_bag(bag, odom_topic="/joint_states")


def test_a_truncated_bag_gets_one_clear_error(bag):
    storage = next(bag.glob("*.mcap"))
    data = storage.read_bytes()
    storage.write_bytes(data[:len(data) // 2])
    with pytest.raises(IdentificationError, match="cannot read the bag .*truncated or damaged"):
        read_bag(bag)


def test_not_a_bag_is_refused(tmp_path, bag):
    with pytest.raises(IdentificationError, match="does not exist"):
        read_bag(tmp_path / "nowhere")
    shutil.copytree(bag, tmp_path / "copy")
    (tmp_path / "copy" / "metadata.yaml").unlink()
    with pytest.raises(IdentificationError, match="has no metadata.yaml"):
        read_bag(tmp_path / "copy")


def copy_bag(source, target, topics, storage=None):
    """The messages of ``topics`` rewritten with rosbags' writer (MCAP, or ``storage``)."""
    from rosbags.highlevel import AnyReader
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    with AnyReader([source], default_typestore=store) as reader, \
            Writer(target, version=8, storage_plugin=storage or StoragePlugin.MCAP) as writer:
        wanted = [c for c in reader.connections if c.topic in topics]
        out = {c.topic: writer.add_connection(c.topic, c.msgtype, typestore=store) for c in wanted}
        for connection, stamp, raw in reader.messages(connections=wanted):
            writer.write(out[connection.topic], stamp, raw)
    return target


def test_a_vehicle_without_an_arm_needs_no_joint_states(tmp_path, bag):
    """arm_joints=() (uvms identify passes the model's): the joint-states topic is optional, as in a CSV log."""
    vehicle = copy_bag(bag, tmp_path / "vehicle", ("/odom", "/body_wrench"))
    with pytest.raises(IdentificationError, match="the bag has no joint states topic '/joint_states'"):
        read_bag(vehicle, arm_joints=["alpha_axis_e"])
    log = read_bag(vehicle, arm_joints=())
    assert log.joint_names == () and log.joint_position.shape == (61, 0) and log.joint_velocity is None
    _, expected = short_run()
    for name in ("t", "position", "quaternion", "twist", "wrench"):
        np.testing.assert_allclose(getattr(log, name), getattr(expected, name), atol=1e-12, err_msg=name)


def test_a_sqlite3_bag_is_read_too(tmp_path, bag):
    """The same messages rewritten with rosbag2's sqlite3 storage (rosbags' writer)."""
    from rosbags.highlevel import AnyReader
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    with AnyReader([bag], default_typestore=store) as reader, \
            Writer(tmp_path / "sqlite", version=8, storage_plugin=StoragePlugin.SQLITE3) as writer:
        wanted = [c for c in reader.connections if c.topic in ("/odom", "/joint_states", "/body_wrench")]
        out = {c.topic: writer.add_connection(c.topic, c.msgtype, typestore=store) for c in wanted}
        for connection, stamp, raw in reader.messages(connections=wanted):
            writer.write(out[connection.topic], stamp, raw)
    log = read_bag(tmp_path / "sqlite")
    np.testing.assert_allclose(log.wrench, short_run()[1].wrench, atol=1e-12)
