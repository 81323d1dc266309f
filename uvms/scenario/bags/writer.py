"""A run out as a ROS 2 bag (rosbag2, MCAP storage), written without a ROS installation.

The bag is written with the pure-Python ``rosbags`` library (``pip install 'uvms[ros]'``), in rosbag2 metadata
version 8 (read by Humble, Iron and Jazzy), so ``ros2 bag play BAG --clock`` with RViz (``use_sim_time``) or
Foxglove replays it. Frames follow REP-103/105: the model's world frame is ``odom`` (ENU, z up), bodies are
FLU. One message per topic and sample (row k of the run, stamped ``start_time_ns + t[k]``) unless said:

- ``/robot_description`` (std_msgs/String, once at t0, transient local): the robot's URDF text; a robot
  without one (composed by ``mount_arm``) has no such topic (``BagSummary.skipped`` says so).
- ``/tf_static`` (tf2_msgs/TFMessage, once at t0, transient local) and ``/tf`` (tf2_msgs/TFMessage): the
  whole link tree, as robot_state_publisher would give it plus the vehicle: ``odom`` -> vehicle root link
  (the base pose of q), every other link under its URDF parent link (a rigid pair on ``/tf_static``, a pair
  across a moving joint on ``/tf``), links fixed to the model's world (a URDF ``world`` link) under ``odom``,
  and end-effector frames that are not links under their nearest link. Composing the chain from ``odom`` to
  an end effector gives ``robot.fk(q, ee)``; RViz's RobotModel needs nothing else.
- ``/joint_states`` (sensor_msgs/JointState): the arm joints (``robot.arm_joint_names``), position [rad or m]
  from q, velocity from v and effort [N m or N] from a plant run's joint torques.
- ``/odom`` (nav_msgs/Odometry, header ``odom``, child the vehicle root link): the vehicle pose in the world
  and its twist in its own axes (REP-105 child frame: Pinocchio's local body twist, v[0:6] floating,
  [vx, vy, 0, 0, 0, wz] planar). Covariances are zero (exact, simulated). A fixed base has no ``/odom``.
- ``/<frame>/desired_pose`` (geometry_msgs/PoseStamped, header ``odom``): the desired pose of the task frame;
  ``/<frame>/desired_position`` (geometry_msgs/PointStamped) when only the desired position was recorded.
- an actuated run (thrusters, ``simulate`` on an ``ActuatedPlant``): ``/thrusters/<name>/thrust``
  (std_msgs/Float64, [N], the thruster's thrust, as uuv_simulator's thruster topics) and ``/body_wrench``
  (geometry_msgs/WrenchStamped, header the vehicle root link: the thrusters' wrench on the vehicle, body FLU
  [N, N m]).

Stamps: ``start_time_ns`` (default 0, the Unix epoch: a simulated run has no wall time) plus t [s] rounded to
the nanosecond; the bag's receive times are the same stamps.
"""

from __future__ import annotations

import os
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from ...errors import BagExportError
from ...io import outputs
from ...numerics.validate import finite_array, time_vector
from ...robot.robot import Robot
from ...sim.result import SimulationResult
from .tf_tree import WORLD_FRAME, TransformEdge, frame_tree, vehicle_root_link

__all__ = ["BAG_VERSION", "BODY_WRENCH_TOPIC", "BagSummary", "JOINT_STATES_TOPIC", "ODOM_TOPIC", "stamps_ns",
           "write_bag"]

#: rosbag2 metadata version written: 8 keeps the QoS as a YAML string, which Humble's player also reads.
BAG_VERSION = 8
INSTALL_HINT = "writing a ROS 2 bag needs the 'rosbags' package: pip install 'uvms[ros]' (or pip install rosbags)"
#: The topics of the vehicle's odometry, the arm's joint states and the thrusters' body wrench (read back by
#: :mod:`uvms.scenario.bags.reader` for identification).
ODOM_TOPIC = "/odom"
JOINT_STATES_TOPIC = "/joint_states"
BODY_WRENCH_TOPIC = "/body_wrench"
#: A rosbag2 folder's file: without uvms's manifest (``outputs.MANIFEST``), an older uvms's bag; refused all the same.
BAG_MARKERS = ("metadata.yaml",)


@dataclass
class BagSummary:
    """What :func:`write_bag` wrote.

    Attributes:
        path: the bag folder (``metadata.yaml`` and one ``.mcap`` file named after the folder).
        topics: message count per topic, in the order written.
        types: the message type of each topic (e.g. "sensor_msgs/msg/JointState").
        skipped: what was left out, with the reason (e.g. "/robot_description": "the robot has no URDF ...").
    """

    path: Path
    topics: dict[str, int] = field(default_factory=dict)
    types: dict[str, str] = field(default_factory=dict)
    skipped: dict[str, str] = field(default_factory=dict)

    def describe(self) -> str:
        """One line per topic and per skipped item, for a terminal."""
        lines = [f"bag {self.path}"]
        lines += [f"  {topic} ({self.types[topic]}): {count}" for topic, count in self.topics.items()]
        return "\n".join(lines + [f"  skipped {item}: {reason}" for item, reason in self.skipped.items()])


def load_rosbags() -> dict[str, Any]:
    """The parts of ``rosbags`` used here, imported on first use.

    Raises:
        BagExportError: rosbags is not installed (the message gives the install command).
    """
    try:
        from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
        from rosbags.rosbag2 import StoragePlugin, Writer, WriterError
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        raise BagExportError(INSTALL_HINT) from None

    def qos(durability: Any) -> list:
        unset = QosTime(0, 0)  # the middleware's default: infinite
        return [Qos(QosHistory.KEEP_LAST, 1 if durability is QosDurability.TRANSIENT_LOCAL else 10,
                    QosReliability.RELIABLE, durability, unset, unset, QosLiveliness.AUTOMATIC, unset, False)]

    return {"Writer": Writer, "WriterError": WriterError, "mcap": StoragePlugin.MCAP,
            "typestore": get_typestore(Stores.ROS2_HUMBLE), "latched": qos(QosDurability.TRANSIENT_LOCAL),
            "volatile": qos(QosDurability.VOLATILE)}


# ------------------------------------------------------------------ the series
def stamps_ns(t: np.ndarray, start_time_ns: int = 0) -> np.ndarray:
    """Time stamps (N,) [ns since the Unix epoch]: ``start_time_ns`` + t [s], rounded to the nanosecond."""
    if not isinstance(start_time_ns, (int, np.integer)) or isinstance(start_time_ns, bool) or start_time_ns < 0:
        raise BagExportError(f"start_time_ns must be an integer >= 0 [ns since the Unix epoch], got {start_time_ns!r}")
    t = time_vector(t, "the run's t", strict=False, error=BagExportError)
    if t[0] < 0:
        raise BagExportError(f"the run's t must start at or after 0 s, got {t[0]:.6g} s")
    return int(start_time_ns) + np.round(t * 1e9).astype(np.int64)


def desired_series(result: SimulationResult,
                   desired: Sequence[pin.SE3] | np.ndarray | None) -> tuple[np.ndarray, np.ndarray | None] | None:
    """The desired positions (N, 3) [m] and quaternions (N, 4) x, y, z, w (None: position only), world frame.

    Args:
        result: the run; its ``desired_position`` / ``desired_rpy`` are used when ``desired`` is None.
        desired: N poses (``pin.SE3``) or an (N, 4, 4) array of homogeneous transforms; None: from the run.

    Returns:
        None when the run has no desired pose.
    """
    count = len(result.t)
    if desired is None:
        if result.desired_position is None:
            return None
        positions = np.asarray(result.desired_position, dtype=float).reshape(count, 3)
        if result.desired_rpy is None:
            return positions, None
        rotations = [pin.rpy.rpyToMatrix(*rpy) for rpy in np.asarray(result.desired_rpy, dtype=float)]
    else:
        poses = [pin.SE3(pose) if not isinstance(pose, pin.SE3) else pose for pose in desired]
        if len(poses) != count:
            raise BagExportError(f"desired holds {len(poses)} poses; the run has {count} samples")
        positions = np.array([pose.translation for pose in poses]).reshape(count, 3)
        rotations = [pose.rotation for pose in poses]
    return positions, np.array([pin.Quaternion(rotation).coeffs() for rotation in rotations]).reshape(count, 4)


def _check_run(robot: Robot, result: SimulationResult) -> None:
    """The run's series fit the robot: shapes (N, nq), (N, nv), (N, n_arm), (N, 3) and finite entries."""
    count = len(np.atleast_1d(result.t))
    torque = None if result.plant is None else result.plant.joint_torque  # a plant run's motor torques
    series = {"q": (result.q, robot.nq), "v": (result.v, robot.nv), "joint_torque": (torque, robot.n_arm),
              "desired_position": (result.desired_position, 3), "desired_rpy": (result.desired_rpy, 3)}
    for name, (values, width) in series.items():
        if values is not None:
            finite_array(values, f"the run's {name}", (count, width), error=BagExportError)


def topic_token(name: str) -> str:
    """A frame name as one ROS 2 topic token: letters, digits and single underscores, not starting with a digit."""
    token = re.sub(r"_+", "_", re.sub(r"[^A-Za-z0-9_]", "_", name)).strip("_") or "frame"
    return f"frame_{token}" if token[0].isdigit() else token


def thruster_tokens(names: Sequence[str]) -> list[str]:
    """The thrusters' names as topic tokens (``/thrusters/<token>/thrust``), one topic each.

    Raises:
        BagExportError: two names that give the same token (``thruster_1`` and ``thruster.1``), whose thrusts would
            share one topic.
    """
    tokens = [topic_token(name) for name in names]
    owner: dict[str, str] = {}
    for name, token in zip(names, tokens):
        if token in owner:
            raise BagExportError(f"thrusters {owner[token]!r} and {name!r} both become the topic token {token!r} "
                                 "(a topic name holds letters, digits and underscores); rename one of them in the "
                                 "model so that each thruster has its own topic")
        owner[token] = name
    return tokens


# ------------------------------------------------------------------ the messages
class Messages:
    """Builds the ROS 2 messages of a bag from Pinocchio quantities (one ``rosbags`` typestore)."""

    def __init__(self, typestore: Any) -> None:
        self.typestore, self.types = typestore, typestore.types

    def serialize(self, message: Any) -> bytes:
        """CDR bytes of a message."""
        return self.typestore.serialize_cdr(message, message.__msgtype__)

    def header(self, stamp: int, frame_id: str) -> Any:
        seconds, nanoseconds = divmod(int(stamp), 1_000_000_000)
        time = self.types["builtin_interfaces/msg/Time"](sec=seconds, nanosec=nanoseconds)
        return self.types["std_msgs/msg/Header"](stamp=time, frame_id=frame_id)

    def vector(self, values: np.ndarray, kind: str = "Vector3") -> Any:
        return self.types[f"geometry_msgs/msg/{kind}"](x=float(values[0]), y=float(values[1]), z=float(values[2]))

    def quaternion(self, coeffs: np.ndarray) -> Any:
        """From x, y, z, w (Pinocchio's and ROS's order)."""
        x, y, z, w = (float(value) for value in coeffs)
        return self.types["geometry_msgs/msg/Quaternion"](x=x, y=y, z=z, w=w)

    def pose(self, pose: pin.SE3) -> Any:
        return self.types["geometry_msgs/msg/Pose"](position=self.vector(pose.translation, "Point"),
                                                    orientation=self.quaternion(pin.Quaternion(pose.rotation).coeffs()))

    def tf(self, stamp: int, edges: Sequence[TransformEdge], poses: Sequence[pin.SE3]) -> Any:
        """A TFMessage of ``edges``, with the world poses of the model's frames (``data.oMf``)."""
        transforms = []
        for edge in edges:
            child = poses[edge.child_id]
            relative = child if edge.parent_id is None else poses[edge.parent_id].actInv(child)
            transform = self.types["geometry_msgs/msg/Transform"](
                translation=self.vector(relative.translation),
                rotation=self.quaternion(pin.Quaternion(relative.rotation).coeffs()))
            transforms.append(self.types["geometry_msgs/msg/TransformStamped"](
                header=self.header(stamp, edge.parent), child_frame_id=edge.child, transform=transform))
        return self.types["tf2_msgs/msg/TFMessage"](transforms=transforms)

    def joint_state(self, stamp: int, names: list[str], position: np.ndarray, velocity: np.ndarray | None,
                    effort: np.ndarray | None) -> Any:
        empty = np.zeros(0)
        return self.types["sensor_msgs/msg/JointState"](
            header=self.header(stamp, ""), name=list(names), position=np.asarray(position, dtype=np.float64),
            velocity=empty if velocity is None else np.asarray(velocity, dtype=np.float64),
            effort=empty if effort is None else np.asarray(effort, dtype=np.float64))

    def odometry(self, stamp: int, child: str, pose: pin.SE3, twist: pin.Motion) -> Any:
        covariance = np.zeros(36)
        types = self.types
        return types["nav_msgs/msg/Odometry"](
            header=self.header(stamp, WORLD_FRAME), child_frame_id=child,
            pose=types["geometry_msgs/msg/PoseWithCovariance"](pose=self.pose(pose), covariance=covariance),
            twist=types["geometry_msgs/msg/TwistWithCovariance"](
                twist=types["geometry_msgs/msg/Twist"](linear=self.vector(twist.linear),
                                                       angular=self.vector(twist.angular)),
                covariance=covariance))

    def wrench(self, stamp: int, frame_id: str, wrench: np.ndarray) -> Any:
        """geometry_msgs/WrenchStamped of a wrench [f; tau] (6,) [N, N m] in ``frame_id``'s axes."""
        body = self.types["geometry_msgs/msg/Wrench"](force=self.vector(wrench[:3]), torque=self.vector(wrench[3:]))
        return self.types["geometry_msgs/msg/WrenchStamped"](header=self.header(stamp, frame_id), wrench=body)

    def desired(self, stamp: int, position: np.ndarray, quaternion: np.ndarray | None) -> Any:
        header = self.header(stamp, WORLD_FRAME)
        if quaternion is None:
            return self.types["geometry_msgs/msg/PointStamped"](header=header, point=self.vector(position, "Point"))
        pose = self.types["geometry_msgs/msg/Pose"](position=self.vector(position, "Point"),
                                                    orientation=self.quaternion(quaternion))
        return self.types["geometry_msgs/msg/PoseStamped"](header=header, pose=pose)


# ------------------------------------------------------------------ writing
def write_bag(path: str | os.PathLike, robot: Robot, result: SimulationResult, *,
              desired: Sequence[pin.SE3] | np.ndarray | None = None, desired_frame: str | None = None,
              start_time_ns: int = 0, lock: bool = True, thrusters: Sequence[str] = ()) -> BagSummary:
    """Write a run as a rosbag2 folder (MCAP storage) at ``path``, replacing a previous bag whole.

    The topics, frames and stamps are those of the module docstring. Everything is checked before anything
    is written; the bag is written into a hidden temporary folder beside ``path`` that replaces it at the
    end (:func:`uvms.io.outputs.run_folder`), so ``path`` holds a complete bag, the previous one or the new one.

    Args:
        path: the bag folder, e.g. ``RUN_FOLDER / "bag"``; an existing non-empty folder must be a bag folder
            that uvms wrote (its manifest ``.uvms-run.json``) holding nothing else.
        robot: the model of the run.
        result: the run: t (N,) [s], q (N, nq), v (N, nv); joint_torque (N, n_arm) [N m] if any;
            desired_position (N, 3) [m] and desired_rpy (N, 3) [rad] for the desired pose.
        desired: the desired poses of ``desired_frame`` instead of the run's: N ``pin.SE3`` or (N, 4, 4).
        desired_frame: the frame the desired pose is for (the task frame); default the first end effector.
        start_time_ns: the stamp of t = 0 [ns since the Unix epoch]; default 0.
        lock: hold the lock of ``path`` (False for a bag inside a run folder being written, as ``uvms run``).
        thrusters: the thruster names of an actuated run (its ``actuation.thrusts`` columns, in order).

    Returns:
        The topics written with their message counts, and what was skipped and why.

    Raises:
        BagExportError: rosbags is missing, or a run that does not fit the robot (shapes, times).
        FrameNotFound: an unknown ``desired_frame``. RunFolderError: ``path`` cannot be replaced.
    """
    api = load_rosbags()
    stamps = stamps_ns(result.t, start_time_ns)
    _check_run(robot, result)
    thrust = _thrust_series(result, thrusters)
    frame = robot.model.frames[robot.frame_id(desired_frame)].name
    edges, skipped = frame_tree(robot)
    target = desired_series(result, desired)
    if target is None:
        skipped[f"/{topic_token(frame)}/desired_pose"] = "the run has no desired pose"
    if robot.urdf is None:
        skipped["/robot_description"] = "the robot has no URDF text (composed robot): save its URDF and publish it"
    if vehicle_root_link(robot) is None:
        skipped[ODOM_TOPIC] = ("a fixed base has no vehicle" if robot.base_type == "fixed"
                               else "no link on the vehicle joint")
    wide = [joint.name for joint in robot.arm_joints if joint.nv != 1]
    if wide:
        skipped[JOINT_STATES_TOPIC] = f"joints {', '.join(wide)} have several values; JointState holds one per joint"
    summary = BagSummary(path=Path(path), skipped=skipped)
    name = Path(os.path.realpath(os.path.abspath(path))).name
    with outputs.run_folder(path, lock=lock, legacy_markers=BAG_MARKERS) as folder:
        staging = folder / name  # rosbags names the .mcap after its folder: NAME/NAME.mcap once moved up
        try:
            _write(api, staging, robot, result, stamps, edges, frame, target, summary, thrust)
            for item in list(staging.iterdir()):
                os.replace(item, folder / item.name)
            staging.rmdir()
        except api["WriterError"] as exc:
            raise BagExportError(f"cannot write the bag {os.fspath(path)!r}: {exc}") from None
        except OSError as exc:
            raise BagExportError(f"cannot write the bag {os.fspath(path)!r}: {exc.strerror or exc}") from None
    return summary


def _thrust_series(result: SimulationResult, names: Sequence[str]) -> tuple | None:
    """(names, thrusts (N, n) [N], body wrench (N, 6)) of an actuated run, or None.

    Raises:
        BagExportError: names given that do not match the run's thrust columns, or two that share a topic.
    """
    actuation = result.actuation
    if not names or actuation is None:
        return None
    thrusts = np.asarray(actuation.thrusts)
    if thrusts.shape != (len(result.t), len(names)):
        raise BagExportError(f"{len(names)} thruster names for thrusts of shape {thrusts.shape}")
    return thruster_tokens(names), thrusts, np.asarray(actuation.body_wrench)


def _write(api: dict[str, Any], staging: Path, robot: Robot, result: SimulationResult, stamps: np.ndarray,
           edges: list[TransformEdge], frame: str, target: tuple | None, summary: BagSummary,
           thrust: tuple | None = None) -> None:
    """Write every message into a new bag folder ``staging``; fill ``summary``'s topics."""
    messages = Messages(api["typestore"])
    model, data = robot.model, robot.model.createData()
    root = vehicle_root_link(robot)
    with api["Writer"](staging, version=BAG_VERSION, storage_plugin=api["mcap"]) as writer:
        connections: dict[str, Any] = {}

        def put(topic: str, stamp: int, message: Any, qos: str = "volatile") -> None:
            if topic not in connections:
                connections[topic] = writer.add_connection(topic, message.__msgtype__, typestore=api["typestore"],
                                                           offered_qos_profiles=api[qos])
                summary.types[topic], summary.topics[topic] = message.__msgtype__, 0
            writer.write(connections[topic], int(stamp), messages.serialize(message))
            summary.topics[topic] += 1

        if robot.urdf is not None:
            put("/robot_description", stamps[0], messages.types["std_msgs/msg/String"](data=robot.urdf), "latched")
        static = [edge for edge in edges if edge.static]
        moving = [edge for edge in edges if not edge.static]
        velocities = result.v if result.v is not None else np.zeros((len(stamps), robot.nv))
        for k, stamp in enumerate(stamps):
            q = robot.check_configuration(result.q[k])
            pin.forwardKinematics(model, data, q, velocities[k])
            pin.updateFramePlacements(model, data)
            poses = [pin.SE3(pose) for pose in data.oMf]
            if k == 0 and static:
                put("/tf_static", stamp, messages.tf(stamp, static, poses), "latched")
            if moving:
                put("/tf", stamp, messages.tf(stamp, moving, poses))
            if JOINT_STATES_TOPIC not in summary.skipped:
                put(JOINT_STATES_TOPIC, stamp, _joint_state(messages, robot, result, k, stamp, q))
            if root is not None:
                twist = pin.getFrameVelocity(model, data, root, pin.ReferenceFrame.LOCAL)
                put(ODOM_TOPIC, stamp, messages.odometry(stamp, model.frames[root].name, poses[root], twist))
            if target is not None:
                kind = "desired_pose" if target[1] is not None else "desired_position"
                put(f"/{topic_token(frame)}/{kind}", stamp,
                    messages.desired(stamp, target[0][k], None if target[1] is None else target[1][k]))
            if thrust is not None:
                names, thrusts, wrenches = thrust
                for index, name in enumerate(names):
                    put(f"/thrusters/{name}/thrust", stamp, messages.types["std_msgs/msg/Float64"](
                        data=float(thrusts[k, index])))
                if root is not None:
                    put(BODY_WRENCH_TOPIC, stamp, messages.wrench(stamp, model.frames[root].name, wrenches[k]))


def _joint_state(messages: Messages, robot: Robot, result: SimulationResult, k: int, stamp: int, q: np.ndarray) -> Any:
    """The arm joints of row k: positions from q, velocities from v, efforts from a plant run's torques."""
    velocity = None if result.v is None else np.asarray(result.v[k, robot.n_vehicle:])
    effort = None if result.plant is None else np.asarray(result.plant.joint_torque[k])
    return messages.joint_state(stamp, robot.arm_joint_names, robot.arm_configuration(q), velocity, effort)

