"""A ROS 2 bag read back as a log for hydrodynamic identification (the pure-Python ``rosbags`` library).

Reads a rosbag2 folder (MCAP or sqlite3 storage; the folder with ``metadata.yaml``, or one of its files) with

- ``nav_msgs/msg/Odometry`` (default ``/odom``): the vehicle root link's pose in the world and its body twist
  in its own axes (REP-105), as :mod:`uvms.scenario.rosbag` writes them;
- ``sensor_msgs/msg/JointState`` (default ``/joint_states``): the arm's joint positions and velocities
  (velocities optional: without them they are differentiated from the positions);
- ``geometry_msgs/msg/WrenchStamped`` (default ``/body_wrench``): the thrusters' wrench on the vehicle, in the
  odometry's child frame (body FLU at the root link's origin); or, with ``thrust``, one ``std_msgs/msg/Float64``
  topic per thruster (thrusts or commands) mapped through the model's thrusters (:mod:`uvms.scenario.thrust_log`).

Stamps are the messages' header stamps (the bag's receive times for Float64, which has no header). The joint states and the wrench are interpolated linearly at the
odometry's stamps; odometry samples outside their time span are dropped. The topic names default to those the
writer uses (:data:`uvms.scenario.rosbag.ODOM_TOPIC` ...).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from ..dynamics.identification_data import IdentificationLog
from ..errors import IdentificationError
from .rosbag import BODY_WRENCH_TOPIC, INSTALL_HINT, JOINT_STATES_TOPIC, ODOM_TOPIC
from .thrust_log import ThrustInput

#: The message type each role needs.
MESSAGE_TYPES = {"odometry": "nav_msgs/msg/Odometry", "joint states": "sensor_msgs/msg/JointState",
                 "wrench": "geometry_msgs/msg/WrenchStamped", "thrust": "std_msgs/msg/Float64"}


def bag_folder(path: str | os.PathLike) -> Path:
    """The rosbag2 folder of ``path`` (the folder itself, or the folder of one of its storage files).

    Raises:
        IdentificationError: no such path, or no ``metadata.yaml`` beside it.
    """
    path = Path(path)
    if not path.exists():
        raise IdentificationError(f"the log {str(path)!r} does not exist; give a rosbag2 folder or a CSV file")
    folder = path if path.is_dir() else path.parent
    if not (folder / "metadata.yaml").is_file():
        raise IdentificationError(f"{str(path)!r} is not a rosbag2 recording: {folder} has no metadata.yaml (give "
                                  "the bag's folder, as ros2 bag record writes it)")
    return folder


def read_bag(path: str | os.PathLike, *, odom_topic: str = ODOM_TOPIC, joint_states_topic: str = JOINT_STATES_TOPIC,
             wrench_topic: str = BODY_WRENCH_TOPIC, thrust: ThrustInput | None = None) -> IdentificationLog:
    """The log of a rosbag2 recording (module docstring); with ``thrust`` (:func:`uvms.scenario.thrust_log.thrust_input`)
    the wrench is that of the thruster topics, and ``wrench_topic`` is not read.

    Raises:
        IdentificationError: rosbags missing, a truncated or unreadable bag, a missing topic, a wrong message
            type, joint states without some joint, a wrench in another frame, non-finite values, too few samples.
    """
    folder = bag_folder(path)
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        raise IdentificationError(INSTALL_HINT.replace("writing", "reading")) from None
    topics = {"odometry": odom_topic, "joint states": joint_states_topic}
    if thrust is None:
        topics["wrench"] = wrench_topic
    else:
        topics.update({f"thrust of {name}": topic for name, topic in zip(thrust.names, thrust.topics)})
    try:
        with AnyReader([folder], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
            connections = _connections(reader, topics, folder)
            messages: dict[str, list[tuple[float, Any]]] = {role: [] for role in topics}
            role_of = {id(connection): role for role, connection in connections.items()}
            for connection, received, raw in reader.messages(connections=list(connections.values())):
                message = reader.deserialize(raw, connection.msgtype)
                header = getattr(message, "header", None)
                stamp = 1e-9 * received if header is None else header.stamp.sec + 1e-9 * header.stamp.nanosec
                messages[role_of[id(connection)]].append((stamp, message))
    except IdentificationError:
        raise
    except Exception as exc:  # noqa: BLE001 - a broken file raises anything from the storage (AnyReaderError...)
        raise IdentificationError(f"cannot read the bag {str(folder)!r} (truncated or damaged?): "
                                  f"{type(exc).__name__}: {' '.join(str(exc).split())}; a complete rosbag2 "
                                  "recording is needed (ros2 bag reindex may repair one)") from None
    return _log(messages, topics, folder, thrust)


def _connections(reader: Any, topics: dict[str, str], folder: Path) -> dict[str, Any]:
    """The connection of each role, checked: present, of the right message type."""
    present = {connection.topic: connection for connection in reader.connections}
    chosen = {}
    for role, topic in topics.items():
        if topic not in present:
            raise IdentificationError(f"{folder}: the bag has no {role} topic {topic!r} (its topics: "
                                      f"{', '.join(sorted(present)) or 'none'}); name it with the topic option")
        wanted = MESSAGE_TYPES[role.split(" of ")[0]]
        if present[topic].msgtype != wanted:
            raise IdentificationError(f"{folder}: topic {topic!r} holds {present[topic].msgtype}; the {role} must "
                                      f"be {wanted}")
        chosen[role] = present[topic]
    return chosen


def _vector(message: Any) -> list[float]:
    return [message.x, message.y, message.z]


def _wrench_series(messages: dict[str, list[tuple[float, Any]]], topics: dict[str, str], folder: Path, child: str,
                   thrust: ThrustInput | None) -> list[tuple[np.ndarray, np.ndarray]]:
    """(stamps (N_i,), values (N_i, 6 or 1)) of the wrench topic, or of each thruster's thrust (a column each)."""
    if thrust is not None:
        series = []
        for index, name in enumerate(thrust.names):
            items = sorted(messages[f"thrust of {name}"], key=lambda item: item[0])
            stamps = np.array([stamp for stamp, _ in items])
            series.append((stamps, thrust.thrust(index, stamps, np.array([m.data for _, m in items]))[:, None]))
        return series
    items = sorted(messages["wrench"], key=lambda item: item[0])
    frames = {message.header.frame_id for _, message in items}
    if frames - {child, ""}:
        raise IdentificationError(f"{folder}: the wrench on {topics['wrench']!r} is in frame(s) "
                                  f"{', '.join(sorted(frames))}; it must be in the odometry's child frame {child!r}")
    return [(np.array([stamp for stamp, _ in items]),
             np.array([_vector(m.wrench.force) + _vector(m.wrench.torque) for _, m in items]))]


def _log(messages: dict[str, list[tuple[float, Any]]], topics: dict[str, str], folder: Path,
         thrust: ThrustInput | None = None) -> IdentificationLog:
    """The arrays of the messages, the joint states and wrench interpolated at the odometry's stamps."""
    for role, items in messages.items():
        if len(items) < 2:
            raise IdentificationError(f"{folder}: the {role} topic {topics[role]!r} holds {len(items)} message(s); "
                                      "identification needs a time series")
    odometry = sorted(messages["odometry"], key=lambda item: item[0])
    t = np.array([stamp for stamp, _ in odometry])
    pose = [message.pose.pose for _, message in odometry]
    twist = [message.twist.twist for _, message in odometry]
    wrenches = _wrench_series(messages, topics, folder, odometry[0][1].child_frame_id, thrust)
    joints = sorted(messages["joint states"], key=lambda item: item[0])
    names = list(joints[0][1].name)
    joint_t = np.array([stamp for stamp, _ in joints])
    position, velocity = _joint_arrays(joints, names, folder, topics["joint states"])
    start = max(t[0], joint_t[0], *(stamps[0] for stamps, _ in wrenches)) + (thrust.settling if thrust else 0.0)
    stop = min(t[-1], joint_t[-1], *(stamps[-1] for stamps, _ in wrenches))
    keep = (t >= start) & (t <= stop)
    t = t[keep]

    def at_odometry(times: np.ndarray, values: np.ndarray | None) -> np.ndarray | None:
        if values is None:
            return None
        return np.column_stack([np.interp(t, times, values[:, i]) for i in range(values.shape[1])]) \
            if values.shape[1] else np.zeros((len(t), 0))

    return IdentificationLog(
        t - t[0] if len(t) else t,
        np.array([_vector(p.position) for p in pose])[keep],
        np.array([_vector(p.orientation) + [p.orientation.w] for p in pose])[keep],
        np.array([_vector(w.linear) + _vector(w.angular) for w in twist])[keep],
        _wrench_at(wrenches, at_odometry, thrust), tuple(names), at_odometry(joint_t, position),
        at_odometry(joint_t, velocity),
        str(folder))


def _wrench_at(wrenches: list[tuple[np.ndarray, np.ndarray]], at_odometry, thrust: ThrustInput | None) -> np.ndarray:
    """The wrench (K, 6) at the odometry's stamps: the topic's, or B f of the thrusts interpolated there."""
    if thrust is None:
        return at_odometry(*wrenches[0])
    thrusts = np.hstack([at_odometry(stamps, values) for stamps, values in wrenches])  # (K, n)
    return thrusts @ thrust.matrix.T


def _joint_arrays(joints: list[tuple[float, Any]], names: list[str], folder: Path,
                  topic: str) -> tuple[np.ndarray, np.ndarray | None]:
    """Positions (N, n) and velocities (N, n) or None, in the order of ``names``."""
    positions, velocities = [], []
    for stamp, message in joints:
        index = {name: k for k, name in enumerate(message.name)}
        missing = [name for name in names if name not in index]
        if missing or len(message.position) != len(message.name):
            raise IdentificationError(f"{folder}: the joint state on {topic!r} at t = {stamp:.6g} s lacks "
                                      f"{', '.join(missing) or 'positions'}; every message must hold every joint")
        order = [index[name] for name in names]
        positions.append(np.asarray(message.position, dtype=float)[order])
        has_velocity = len(message.velocity) == len(message.name)
        velocities.append(np.asarray(message.velocity, dtype=float)[order] if has_velocity else None)
    if any(row is None for row in velocities):
        return np.array(positions), None
    return np.array(positions), np.array(velocities)
