"""Batched forward kinematics built from the Pinocchio model: many joint samples at once, in chunks."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from ..errors import UVMSError, WorkspaceInputError
from ..robot.robot import Robot, check_robot

#: Samples composed at once by `BatchKinematics` and drawn at once by `monte_carlo` (its default chunk): the
#: work arrays of one chunk take some 50-90 MB, whatever the sample count.
CHUNK = 200_000
#: Samples carried through a chain at once inside a chunk (`BatchKinematics.carried_blocks`): their work arrays
#: (some 100-400 kB) stay in the CPU cache.
BLOCK = 8192
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
        check_robot(self.robot, "BatchKinematics")
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
        """Frame positions (N, 3) [m] in the world for joint values (N, n), the vehicle at ``base`` (default: origin).

        Only the point is carried from the frame back to the root (`carried_blocks`): per joint
        one rotation of N vectors about a constant axis and one constant 3x3 product, several
        times cheaper than composing N rotation matrices.
        """
        values = self._check_values(values)
        out = np.empty((values.shape[0], 3))
        for rows, carried in self.carried_blocks(values, "", base):
            out[rows] = carried[0].T
        return out

    def positions_and_axes(self, values: np.ndarray, axes: str = "xyz",
                           base: pin.SE3 | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Frame positions (N, 3) [m] and some of the frame's axes (N, k, 3) in the world, for joint values (N, n).

        Like `positions`, the point and the k axis vectors are carried together from the frame
        back to the root (one cosine and sine per joint and sample for all of them), which is
        cheaper than composing rotation matrices when fewer than three axes are needed.

        Args:
            values: joint values (N, n) [rad or m].
            axes: which axes, in order, e.g. "zx" (k = len(axes) letters of "xyz").
            base: pose of the vehicle (default: the origin).
        """
        if not axes or any(axis not in AXES for axis in axes):
            raise WorkspaceInputError(f"axes must be letters of 'xyz', got {axes!r}")
        values = self._check_values(values)
        count = values.shape[0]
        position_out, axes_out = np.empty((count, 3)), np.empty((count, len(axes), 3))
        for rows, carried in self.carried_blocks(values, axes, base):
            position_out[rows] = carried[0].T
            axes_out[rows] = carried[1:].transpose(2, 0, 1)
        return position_out, axes_out

    def poses(self, values: np.ndarray, base: pin.SE3 | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Frame rotations (N, 3, 3) (columns: the frame axes in the world), positions (N, 3) [m], for values (N, n)."""
        values = self._check_values(values)
        count = values.shape[0]
        rotation_out, position_out = np.empty((count, 3, 3)), np.empty((count, 3))
        for rows, carried in self.carried_blocks(values, "xyz", base):
            position_out[rows] = carried[0].T
            rotation_out[rows] = carried[1:].transpose(2, 1, 0)
        return rotation_out, position_out

    def carried_blocks(self, values: np.ndarray, axes: str, base: pin.SE3 | None = None
                       ) -> Iterator[tuple[slice, np.ndarray]]:
        """The frame's origin and axes carried to the world, ``BLOCK`` samples at a time.

        Vectors are stored coordinate-major, (1 + k, 3, n): row 0 the point, then the k axes
        named by ``axes``; per joint, from the frame back to the root, they turn about the
        joint axis (revolute) or the point slides along it (prismatic), then the constant
        joint placement applies. The blocks are small enough for the work arrays to stay in
        the CPU cache.

        Args:
            values: checked joint values (N, n) [rad or m].
            axes: letters of "xyz" (may be empty).
            base: pose of the vehicle (default: the origin).

        Yields:
            (rows of ``values``, vectors (1 + k, 3, n) in the world).
        """
        if any(axis not in AXES for axis in axes):
            raise WorkspaceInputError(f"axes must be letters of 'xyz', got {axes!r}")
        root = self._root_pose(base)
        placement = self.frame_placement
        start_vectors = np.column_stack([placement.translation] + [placement.rotation[:, AXES[a]] for a in axes]).T
        for start in range(0, values.shape[0], BLOCK):
            chunk = values[start:start + BLOCK]
            vectors = np.repeat(start_vectors[:, :, None], chunk.shape[0], axis=2)  # (1 + k, 3, n)
            for step in reversed(self.steps):
                value = chunk[:, step.column]
                if step.revolute:
                    turn(vectors, step.axis, np.cos(value), np.sin(value))
                else:
                    shift(vectors[0], step.axis, value)
                vectors = rotate_and_shift(vectors, step.placement_rotation, step.placement_translation)
            yield slice(start, start + chunk.shape[0]), rotate_and_shift(vectors, root.rotation, root.translation)

    def _check_values(self, values: np.ndarray) -> np.ndarray:
        values = np.atleast_2d(np.asarray(values, dtype=float))
        if values.shape[1] != len(self.joint_names) or not np.all(np.isfinite(values)):
            raise UVMSError(f"joint values must be finite with {len(self.joint_names)} columns "
                            f"({', '.join(self.joint_names)}), got shape {values.shape}")
        return values

    def _root_pose(self, base: pin.SE3 | None) -> pin.SE3:
        """World pose of the joint the chain starts from: the vehicle body (oMi[1], see Robot.base_pose) or the
        world."""
        if self.root_joint == 0 or base is None:
            return pin.SE3.Identity()
        return base


def turn(vectors: np.ndarray, axis: np.ndarray, cos: np.ndarray, sin: np.ndarray) -> None:
    """Rotate vectors (m, 3, n) in place about a unit axis (3,) by angles given by their cosines and sines (n,).

    About +-x, +-y or +-z only the two other coordinates change (a plane rotation);
    any other axis takes Rodrigues' formula.
    """
    aligned = np.flatnonzero(np.abs(axis) == 1.0)
    if aligned.size == 1:
        k = int(aligned[0])
        i, j = (k + 1) % 3, (k + 2) % 3
        sin = sin * axis[k]
        first, second = vectors[:, i], vectors[:, j]  # (m, n) views
        new_first = first * cos - second * sin
        vectors[:, j] = first * sin + second * cos
        vectors[:, i] = new_first
        return
    x, y, z = vectors[:, 0], vectors[:, 1], vectors[:, 2]
    along = (x * axis[0] + y * axis[1] + z * axis[2]) * (1.0 - cos)
    cross = (axis[1] * z - axis[2] * y, axis[2] * x - axis[0] * z, axis[0] * y - axis[1] * x)
    rotated = [vectors[:, r] * cos + cross[r] * sin + along * axis[r] for r in range(3)]
    for r in range(3):
        vectors[:, r] = rotated[r]


def shift(point: np.ndarray, axis: np.ndarray, value: np.ndarray) -> None:
    """Slide a point (3, n) in place along a unit axis (3,) by values (n,) [m]."""
    for r in np.flatnonzero(axis):
        point[r] += axis[r] * value


def rotate_and_shift(vectors: np.ndarray, rotation: np.ndarray, translation: np.ndarray) -> np.ndarray:
    """A constant rigid transform of vectors (m, 3, n): rotation (3, 3) applied to all, translation (3,) added to row 0.

    Exact zeros and unit entries of the rotation cost nothing (a joint placement is mostly
    zeros and ones), so the product is a few scaled additions of (m, n) rows.

    Returns:
        The transformed vectors (m, 3, n), a new array.
    """
    out = np.empty_like(vectors)
    for r in range(3):
        row = out[:, r]
        terms = [(c, float(rotation[r, c])) for c in range(3) if rotation[r, c] != 0.0]
        if not terms:
            row[...] = 0.0
        for index, (c, weight) in enumerate(terms):
            source = vectors[:, c]
            if index == 0:
                np.multiply(source, weight, out=row) if weight != 1.0 else np.copyto(row, source)
            else:
                row += source if weight == 1.0 else source * weight
        if translation[r] != 0.0:
            out[0, r] += translation[r]
    return out


def rotate_points(points: np.ndarray, axis: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Points (N, 3) rotated about a unit axis (3,) through the origin by angles (N,) [rad] (see `turn`)."""
    vectors = np.ascontiguousarray(np.asarray(points, dtype=float).T)[None]  # (1, 3, N)
    turn(vectors, np.asarray(axis, dtype=float), np.cos(angles), np.sin(angles))
    return vectors[0].T.copy()


def axis_rotations(axis: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Rotations (N, 3, 3) about a unit axis (3,) by angles (N,) [rad]: the unit vectors turned (see `turn`)."""
    angles = np.asarray(angles, dtype=float).ravel()
    columns = np.repeat(np.eye(3)[:, :, None], angles.size, axis=2)  # (3 columns, 3, N)
    turn(columns, np.asarray(axis, dtype=float), np.cos(angles), np.sin(angles))
    return columns.transpose(2, 1, 0).copy()
