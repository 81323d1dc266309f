"""A ROS 2 bag read back as a log for hydrodynamic identification (the pure-Python ``rosbags`` library).

Reads a rosbag2 folder (MCAP or sqlite3 storage; the folder with ``metadata.yaml``, or one of its files) with

- ``nav_msgs/msg/Odometry`` (default ``/odom``): the vehicle root link's pose in the world and its body twist
  in its own axes (REP-105), as :mod:`uvms.scenario.bags.writer` writes them;
- ``sensor_msgs/msg/JointState`` (default ``/joint_states``): the arm's joint positions and velocities
  (velocities optional: without them they are differentiated from the positions); optional for a vehicle without
  an arm (``arm_joints=()``);
- ``geometry_msgs/msg/WrenchStamped`` (default ``/body_wrench``): the thrusters' wrench on the vehicle, in the
  odometry's child frame (body FLU at the root link's origin); or, with ``thrust``, one ``std_msgs/msg/Float64``
  topic per thruster (thrusts or commands) mapped through the model's thrusters (:mod:`uvms.scenario.bags.thrust_log`).

Stamps are the messages' header stamps (the bag's receive times for Float64, which has no header). The joint
states and the wrench are interpolated linearly at the odometry's stamps; odometry samples outside their time span are
dropped. The topic names default to those the writer uses (:data:`uvms.scenario.bags.writer.ODOM_TOPIC` ...). A bag is a
stranger's file: it is checked before it is read (:mod:`uvms.scenario.bags.limits`).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ...dynamics.identification.data import MAX_LOG_SAMPLES, IdentificationLog
from ...errors import IdentificationError
from .limits import check_bag, check_topic_count, damaged
from .thrust_log import ThrustInput
from .writer import BODY_WRENCH_TOPIC, INSTALL_HINT, JOINT_STATES_TOPIC, ODOM_TOPIC

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
             wrench_topic: str = BODY_WRENCH_TOPIC, thrust: ThrustInput | None = None,
             arm_joints: Sequence[str] | None = None) -> IdentificationLog:
    """The log of a rosbag2 recording (module docstring); with ``thrust``
    (:func:`uvms.scenario.bags.thrust_log.thrust_input`) the wrench is that of the thruster topics, and ``wrench_topic``
    is not read.

    The bag is checked first (:func:`uvms.scenario.bags.limits.check_bag`: sizes, counts, compression, storage), and
    read with ROS 2's standard message definitions (a bag whose own definition of a type read here differs is
    refused); at most :data:`~uvms.dynamics.identification.data.MAX_LOG_SAMPLES` messages per topic are kept.

    Args:
        arm_joints: the model's arm joints; an empty sequence (a vehicle without an arm) makes the joint-states
            topic optional. None: the topic is required.

    Raises:
        IdentificationError: rosbags missing, a truncated, unreadable or unbounded bag, a missing topic, a wrong
            message type or definition, joint states without some joint, a wrench in another frame, non-finite
            values, too few or too many samples.
    """
    folder = bag_folder(path)
    try:
        from rosbags.rosbag2 import Reader
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        raise IdentificationError(INSTALL_HINT.replace("writing", "reading")) from None
    topics = {"odometry": odom_topic, "joint states": joint_states_topic}
    if thrust is None:
        topics["wrench"] = wrench_topic
    else:
        topics.update({f"thrust of {name}": topic for name, topic in zip(thrust.names, thrust.topics)})
    check_bag(folder, topics)
    store = get_typestore(Stores.ROS2_HUMBLE)
    try:
        with Reader(folder) as reader:
            optional = ("joint states",) if arm_joints is not None and not len(arm_joints) else ()
            connections = _connections(reader, topics, folder, store, optional)
            samples: dict[str, list[tuple]] = {role: [] for role in connections}
            role_of = {id(connection): role for role, connection in connections.items()}
            for connection, received, raw in reader.messages(connections=list(connections.values())):
                role = role_of[id(connection)]
                if len(samples[role]) == MAX_LOG_SAMPLES:
                    check_topic_count(folder, connection.topic, MAX_LOG_SAMPLES + 1)
                samples[role].append(_sample(role, store.deserialize_cdr(raw, connection.msgtype), received,
                                             samples[role]))
    except IdentificationError:
        raise
    except Exception as exc:  # noqa: BLE001 - a broken file raises anything from the storage (ReaderError...)
        raise damaged(folder, f"{type(exc).__name__}: {' '.join(str(exc).split())}") from None
    return _log(samples, topics, folder, thrust)


def _connections(reader: Any, topics: dict[str, str], folder: Path, store: Any,
                 optional: tuple[str, ...] = ()) -> dict[str, Any]:
    """The connection of each role, checked: present (unless ``optional``), of the right message type, with
    ROS 2's standard definition of it."""
    present = {connection.topic: connection for connection in reader.connections}
    chosen = {}
    for role, topic in topics.items():
        if topic not in present and role in optional:
            continue
        if topic not in present:
            raise IdentificationError(f"{folder}: the bag has no {role} topic {topic!r} (its topics: "
                                      f"{', '.join(sorted(present)) or 'none'}); name it with the topic option")
        wanted = MESSAGE_TYPES[role.split(" of ")[0]]
        if present[topic].msgtype != wanted:
            raise IdentificationError(f"{folder}: topic {topic!r} holds {present[topic].msgtype}; the {role} must "
                                      f"be {wanted}")
        if not _standard_definition(present[topic].msgdef, wanted, store):
            raise IdentificationError(f"{folder}: topic {topic!r} carries its own definition of {wanted}, which "
                                      "differs from ROS 2's standard one; uvms reads the standard message (record the "
                                      "bag with the standard message packages)")
        chosen[role] = present[topic]
    return chosen


def _standard_definition(definition: Any, msgtype: str, store: Any) -> bool:
    """Whether a bag's own message definition (none, or MSG/IDL text) of ``msgtype`` is the standard one (the same
    RIHS01 hash of the type and every type it holds)."""
    from rosbags.interfaces import MessageDefinitionFormat
    from rosbags.typesys import (
        Stores,
        get_types_from_idl,
        get_types_from_msg,
        get_typestore,
    )

    if definition.format == MessageDefinitionFormat.NONE:
        return True
    try:
        if definition.format == MessageDefinitionFormat.MSG:
            types = get_types_from_msg(definition.data, msgtype)
        else:  # IDL, one or several (each after a line of '=' and "IDL: <name>")
            separator = "=" * 80 + "\n"
            parts = definition.data.split(separator)[1:] if definition.data.startswith(f"{separator}IDL: ") \
                else [f"IDL: {msgtype}\n{definition.data}"]
            types = {}
            for part in parts:
                types.update(get_types_from_idl(part.split("\n", 1)[1]))
        own = get_typestore(Stores.EMPTY)
        own.register(types)
        return own.hash_rihs01(msgtype) == store.hash_rihs01(msgtype)
    except Exception:  # noqa: BLE001 - a definition rosbags cannot parse is not the standard one
        return False


def _sample(role: str, message: Any, received: int, previous: list[tuple]) -> tuple:
    """The numbers of one message that identification uses (not the message: a log holds up to
    MAX_LOG_SAMPLES of them): (stamp [s], ...) per role; a name equal to the previous message's shares its string."""
    if role == "odometry":
        pose, twist = message.pose.pose, message.twist.twist
        return (_stamp(message), message.child_frame_id, _vector(pose.position) + _vector(pose.orientation)
                + [pose.orientation.w] + _vector(twist.linear) + _vector(twist.angular))
    if role == "joint states":
        names = tuple(message.name)
        if previous and previous[-1][1] == names:
            names = previous[-1][1]
        return (_stamp(message), names, np.array(message.position, dtype=float),
                np.array(message.velocity, dtype=float))
    if role == "wrench":
        wrench = message.wrench
        return _stamp(message), message.header.frame_id, _vector(wrench.force) + _vector(wrench.torque)
    return 1e-9 * received, float(message.data)  # std_msgs/Float64 has no header: the bag's receive time


def _stamp(message: Any) -> float:
    """The header stamp [s]."""
    return message.header.stamp.sec + 1e-9 * message.header.stamp.nanosec


def _vector(message: Any) -> list[float]:
    return [message.x, message.y, message.z]


def _wrench_series(samples: dict[str, list[tuple]], topics: dict[str, str], folder: Path, child: str,
                   thrust: ThrustInput | None) -> list[tuple[np.ndarray, np.ndarray]]:
    """(stamps (N_i,), values (N_i, 6 or 1)) of the wrench topic, or of each thruster's thrust (a column each)."""
    if thrust is not None:
        series = []
        for index, name in enumerate(thrust.names):
            items = sorted(samples[f"thrust of {name}"], key=lambda item: item[0])
            stamps = np.array([stamp for stamp, _ in items])
            series.append((stamps, thrust.thrust(index, stamps, np.array([value for _, value in items]))[:, None]))
        return series
    items = sorted(samples["wrench"], key=lambda item: item[0])
    frames = {frame for _, frame, _ in items}
    if frames - {child, ""}:
        shown = ", ".join(repr(frame) for frame in sorted(frames)[:5])
        raise IdentificationError(f"{folder}: the wrench on {topics['wrench']!r} is in frame(s) {shown}; it must be "
                                  f"in the odometry's child frame {child!r}")
    return [(np.array([stamp for stamp, _, _ in items]), np.array([values for _, _, values in items]))]


def _log(samples: dict[str, list[tuple]], topics: dict[str, str], folder: Path,
         thrust: ThrustInput | None = None) -> IdentificationLog:
    """The arrays of the samples, the joint states and wrench interpolated at the odometry's stamps (no joint-states
    topic: no joints)."""
    for role, items in samples.items():
        if len(items) < 2:
            raise IdentificationError(f"{folder}: the {role} topic {topics[role]!r} holds {len(items)} message(s); "
                                      "identification needs a time series")
    odometry = sorted(samples["odometry"], key=lambda item: item[0])
    t = np.array([stamp for stamp, _, _ in odometry])
    values = np.array([row for _, _, row in odometry])  # (N, 13): position, quaternion x y z w, twist
    wrenches = _wrench_series(samples, topics, folder, odometry[0][1], thrust)
    spans = [(stamps[0], stamps[-1]) for stamps, _ in wrenches]
    names: list[str] = []
    if "joint states" in samples:
        joints = sorted(samples["joint states"], key=lambda item: item[0])
        names = list(joints[0][1])
        joint_t = np.array([stamp for stamp, *_ in joints])
        position, velocity = _joint_arrays(joints, names, folder, topics["joint states"])
        spans.append((joint_t[0], joint_t[-1]))
    start = max(t[0], *(first for first, _ in spans)) + (thrust.settling if thrust else 0.0)
    stop = min(t[-1], *(last for _, last in spans))
    keep = (t >= start) & (t <= stop)
    t, values = t[keep], values[keep]

    def at_odometry(times: np.ndarray, series: np.ndarray | None) -> np.ndarray | None:
        if series is None:
            return None
        return np.column_stack([np.interp(t, times, series[:, i]) for i in range(series.shape[1])]) \
            if series.shape[1] else np.zeros((len(t), 0))

    if "joint states" in samples:
        position, velocity = at_odometry(joint_t, position), at_odometry(joint_t, velocity)
    else:
        position, velocity = np.zeros((len(t), 0)), None
    return IdentificationLog(t - t[0] if len(t) else t, values[:, 0:3], values[:, 3:7], values[:, 7:13],
                             _wrench_at(wrenches, at_odometry, thrust), tuple(names), position, velocity, str(folder))


def _wrench_at(wrenches: list[tuple[np.ndarray, np.ndarray]], at_odometry, thrust: ThrustInput | None) -> np.ndarray:
    """The wrench (K, 6) at the odometry's stamps: the topic's, or B f of the thrusts interpolated there."""
    if thrust is None:
        return at_odometry(*wrenches[0])
    thrusts = np.hstack([at_odometry(stamps, values) for stamps, values in wrenches])  # (K, n)
    return thrusts @ thrust.matrix.T


def _joint_arrays(joints: list[tuple], names: list[str], folder: Path,
                  topic: str) -> tuple[np.ndarray, np.ndarray | None]:
    """Positions (N, n) and velocities (N, n) or None, in the order of ``names``."""
    positions, velocities = [], []
    order: list[int] = []
    last: tuple | None = None
    for stamp, message_names, position, velocity in joints:
        if message_names is not last:  # the same names as the previous message share its tuple (_sample)
            index = {name: k for k, name in enumerate(message_names)}
            missing = [name for name in names if name not in index]
            if missing:
                raise IdentificationError(f"{folder}: the joint state on {topic!r} at t = {stamp:.6g} s lacks "
                                          f"{', '.join(missing[:5])}; every message must hold every joint")
            order, last = [index[name] for name in names], message_names
        if len(position) != len(message_names):
            raise IdentificationError(f"{folder}: the joint state on {topic!r} at t = {stamp:.6g} s has "
                                      f"{len(position)} positions for {len(message_names)} joints; every message must "
                                      "hold every joint's position")
        positions.append(position[order])
        velocities.append(velocity[order] if len(velocity) == len(message_names) else None)
    if any(row is None for row in velocities):
        return np.array(positions), None
    return np.array(positions), np.array(velocities)
