"""Batched forward kinematics built from the Pinocchio model: many joint samples at once, in chunks."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from ..errors import UVMSError, WorkspaceInputError
from ..robot import Robot

#: Samples composed at once by `BatchKinematics` and drawn at once by `monte_carlo` (its default chunk): the
#: work arrays of one chunk take some 50-90 MB, whatever the sample count.
CHUNK = 200_000
#: Frame axes by name, as columns of a rotation matrix.
AXES = {"x": 0, "y": 1, "z": 2}


@dataclass(frozen=True)
class JointStep:
    """One joint on the path to a frame: placement in its parent, axis, kind, and where its value is."""

    placement_rotation: np.ndarray  # (3, 3)
    placement_translation: np.ndarray  # (3,)
    axis: np.ndarray  # (3,) unit
    revolute: bool
    column: int  # index of the joint among the sampled columns


@dataclass
class BatchKinematics:
    """Batched forward kinematics of one frame over the arm joints that move it.

    Attributes:
        robot: the model; frame: the frame name.
        joint_names: the sampled joints (those supporting the frame, vehicle excluded), in chain order.
        lower, upper: their limits (n,) [rad or m].
    """

    robot: Robot
    frame: str
    joint_names: list[str] = field(init=False)
    lower: np.ndarray = field(init=False)
    upper: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        model = self.robot.model
        frame_id = self.robot.frame_id(self.frame)
        frame = model.frames[frame_id]
        path = [j for j in model.supports[frame.parentJoint] if j != 0]
        if self.robot.base_type != "fixed" and path and path[0] == 1:
            path = path[1:]  # the vehicle joint: its pose is given, not sampled
        self.steps: list[JointStep] = []
        names, lower, upper = [], [], []
        for column, joint_id in enumerate(path):
            joint = model.joints[joint_id]
            if joint.nv != 1:
                raise UVMSError(f"joint {model.names[joint_id]!r} ({joint.shortname()}) has {joint.nv} DOF; "
                                f"batched kinematics handles 1-DOF revolute and prismatic joints")
            data = joint.createData()
            joint.calc(data, pin.neutral(model))
            subspace = np.array(data.S).ravel()  # [linear; angular] in the joint frame
            revolute = bool(np.linalg.norm(subspace[3:]) > 0.5)
            axis = subspace[3:] if revolute else subspace[:3]
            placement = model.jointPlacements[joint_id]
            self.steps.append(JointStep(np.array(placement.rotation), np.array(placement.translation),
                                        axis / np.linalg.norm(axis), revolute, column))
            names.append(model.names[joint_id])
            span = slice(joint.idx_q, joint.idx_q + joint.nq)
            bounded = joint.nq == 1
            lower.append(model.lowerPositionLimit[span][0] if bounded else -np.pi)
            upper.append(model.upperPositionLimit[span][0] if bounded else np.pi)
        self.joint_names = names
        self.lower, self.upper = np.array(lower), np.array(upper)
        self.frame_placement = frame.placement
        self.root_joint = 1 if (self.robot.base_type != "fixed") else 0
        self._check_path_is_a_chain(path)

    def _check_path_is_a_chain(self, path: list[int]) -> None:
        model = self.robot.model
        expected_parent = self.root_joint
        for joint_id in path:
            if model.parents[joint_id] != expected_parent:
                raise UVMSError("internal: the support path of a frame must be a chain")
            expected_parent = joint_id

    def sample(self, count: int, rng: np.random.Generator | int | None = None) -> np.ndarray:
        """Joint values (count, n) [rad or m] uniform inside the limits, q_min + (q_max - q_min) rand (xiang2019 eq. 8).

        Row after row from ``rng``: drawing 10 then 20 rows gives the same 30 rows as drawing 30 at once.
        """
        if count < 1:
            raise UVMSError(f"the sample count must be >= 1, got {count}")
        if not (np.all(np.isfinite(self.lower)) and np.all(np.isfinite(self.upper))):
            raise UVMSError(f"joints of {self.frame!r} without finite limits cannot be sampled uniformly")
        rng = np.random.default_rng(rng)
        return self.lower + (self.upper - self.lower) * rng.random((count, len(self.joint_names)))

    def positions(self, values: np.ndarray, base: pin.SE3 | None = None) -> np.ndarray:
        """Frame positions (N, 3) [m] in the world, the vehicle at ``base`` (default: the origin).

        Only points are transformed, from the frame back to the root: per joint one
        rotation of N vectors about a constant axis and one constant 3x3 product,
        several times cheaper than composing N rotation matrices.
        """
        values = self._check_values(values)
        root = self._root_pose(base)
        out = np.empty((values.shape[0], 3))
        for start in range(0, values.shape[0], CHUNK):
            chunk = values[start:start + CHUNK]
            point = np.broadcast_to(self.frame_placement.translation, (chunk.shape[0], 3)).copy()
            for step in reversed(self.steps):
                value = chunk[:, step.column]
                if step.revolute:
                    point = rotate_points(point, step.axis, value)
                else:
                    point += step.axis * value[:, None]
                point = point @ step.placement_rotation.T + step.placement_translation
            out[start:start + CHUNK] = point @ root.rotation.T + root.translation
        return out

    def positions_and_axes(self, values: np.ndarray, axes: str = "xyz",
                           base: pin.SE3 | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Frame positions (N, 3) [m] and some of the frame's axes (N, k, 3) in the world, for joint values (N, n).

        Like `positions`, the point and the k axis vectors are carried from the frame back
        to the root, which is cheaper than composing rotation matrices (`poses`) when
        fewer than three axes are needed.

        Args:
            values: joint values (N, n) [rad or m].
            axes: which axes, in order, e.g. "zx" (k = len(axes) letters of "xyz").
            base: pose of the vehicle (default: the origin).
        """
        if not axes or any(axis not in AXES for axis in axes):
            raise WorkspaceInputError(f"axes must be letters of 'xyz', got {axes!r}")
        values = self._check_values(values)
        root = self._root_pose(base)
        count = values.shape[0]
        position_out, axes_out = np.empty((count, 3)), np.empty((count, len(axes), 3))
        rotation = np.array(self.frame_placement.rotation)
        for start in range(0, count, CHUNK):
            chunk = values[start:start + CHUNK]
            point = np.broadcast_to(self.frame_placement.translation, (chunk.shape[0], 3)).copy()
            vectors = [np.broadcast_to(rotation[:, AXES[axis]], (chunk.shape[0], 3)) for axis in axes]
            for step in reversed(self.steps):
                value = chunk[:, step.column]
                if step.revolute:
                    point = rotate_points(point, step.axis, value)
                    vectors = [rotate_points(vector, step.axis, value) for vector in vectors]
                else:
                    point += step.axis * value[:, None]
                point = point @ step.placement_rotation.T + step.placement_translation
                vectors = [vector @ step.placement_rotation.T for vector in vectors]
            position_out[start:start + CHUNK] = point @ root.rotation.T + root.translation
            for k, vector in enumerate(vectors):
                axes_out[start:start + CHUNK, k] = vector @ root.rotation.T
        return position_out, axes_out

    def _check_values(self, values: np.ndarray) -> np.ndarray:
        values = np.atleast_2d(np.asarray(values, dtype=float))
        if values.shape[1] != len(self.joint_names) or not np.all(np.isfinite(values)):
            raise UVMSError(f"joint values must be finite with {len(self.joint_names)} columns "
                            f"({', '.join(self.joint_names)}), got shape {values.shape}")
        return values

    def poses(self, values: np.ndarray, base: pin.SE3 | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Frame rotations (N, 3, 3) and positions (N, 3) for joint values (N, n)."""
        values = self._check_values(values)
        base_pose = self._root_pose(base)
        count = values.shape[0]
        rotation_out, position_out = np.empty((count, 3, 3)), np.empty((count, 3))
        for start in range(0, count, CHUNK):
            rotation_out[start:start + CHUNK], position_out[start:start + CHUNK] = self._chain(
                values[start:start + CHUNK], base_pose)
        return rotation_out, position_out

    def _root_pose(self, base: pin.SE3 | None) -> pin.SE3:
        """World pose of the joint the chain starts from: the vehicle body (= oMi[1], see Robot.base_pose) or the world."""
        if self.root_joint == 0 or base is None:
            return pin.SE3.Identity()
        return base

    def _chain(self, values: np.ndarray, root: pin.SE3) -> tuple[np.ndarray, np.ndarray]:
        count = values.shape[0]
        rotation = np.broadcast_to(root.rotation, (count, 3, 3)).copy()
        position = np.broadcast_to(root.translation, (count, 3)).copy()
        for step in self.steps:
            position = position + rotation @ step.placement_translation
            rotation = rotation @ step.placement_rotation
            value = values[:, step.column]
            if step.revolute:
                rotation = rotation @ axis_rotations(step.axis, value)
            else:
                position = position + (rotation @ step.axis) * value[:, None]
        placement = self.frame_placement
        position = position + rotation @ placement.translation
        rotation = rotation @ placement.rotation
        return rotation, position


def rotate_points(points: np.ndarray, axis: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Points (N, 3) rotated about a unit axis through the origin by angles (N,) [rad] (Rodrigues)."""
    aligned = np.flatnonzero(np.abs(axis) == 1.0)
    if aligned.size == 1:  # rotation about +-x, +-y or +-z: a plane rotation of the two other coordinates
        k = int(aligned[0])
        i, j = (k + 1) % 3, (k + 2) % 3
        c, s = np.cos(angles), np.sin(angles) * axis[k]
        rotated = points.copy()
        rotated[:, i] = points[:, i] * c - points[:, j] * s
        rotated[:, j] = points[:, i] * s + points[:, j] * c
        return rotated
    c, s = np.cos(angles)[:, None], np.sin(angles)[:, None]
    along = (points @ axis)[:, None] * axis
    return points * c + np.cross(axis, points) * s + along * (1.0 - c)


def axis_rotations(axis: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Rotations (N, 3, 3) about a unit axis by angles (N,) [rad] (Rodrigues)."""
    c, s = np.cos(angles), np.sin(angles)
    x, y, z = axis
    one_c = 1.0 - c
    rotation = np.empty((angles.size, 3, 3))
    rotation[:, 0, 0] = c + x * x * one_c
    rotation[:, 0, 1] = x * y * one_c - z * s
    rotation[:, 0, 2] = x * z * one_c + y * s
    rotation[:, 1, 0] = y * x * one_c + z * s
    rotation[:, 1, 1] = c + y * y * one_c
    rotation[:, 1, 2] = y * z * one_c - x * s
    rotation[:, 2, 0] = z * x * one_c - y * s
    rotation[:, 2, 1] = z * y * one_c + x * s
    rotation[:, 2, 2] = c + z * z * one_c
    return rotation
