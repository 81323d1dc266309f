"""Monte Carlo workspace: uniform joint samples (xiang2019 eq. 8), batched forward kinematics, voxel volume,
dexterity per voxel and removal of the vehicle hull.

The batched forward kinematics is built from the Pinocchio model, not from a
formula: for every joint on the path to the frame it takes Pinocchio's joint
placement and motion subspace S (a revolute joint turns about S's angular
part, a prismatic one slides along its linear part) and composes the poses of
all samples at once with numpy, in chunks so memory stays bounded.

Volumes count occupied cubic voxels. Dexterity (xiang2019 defines the dexterous
workspace, "points an end effector can reach in any orientation", but does not
compute it) is measured per voxel as the fraction of the cells of SO(3) that the
samples falling in the voxel reach; see `OrientationGrid` and `dexterity_map`.
Points are in the vehicle frame (the frame of the vehicle joint; the world for a
fixed base), so the vehicle's own hull, read from the URDF, can be cut out
(`hull_shapes`, `outside_hull`).
"""

from __future__ import annotations

import time
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from .errors import UVMSError
from .robot import Robot

with warnings.catch_warnings():  # tqdm.auto warns in notebooks without ipywidgets, then falls back to text
    warnings.simplefilter("ignore")
    from tqdm.auto import tqdm

#: Samples composed at once; bounds memory to a few hundred MB whatever the sample count.
CHUNK = 200_000


class WorkspaceInputError(UVMSError):
    """A workspace argument out of range: sample count, voxel size, orientation grid, hull."""


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
        """Joint values uniform inside the limits (xiang2019 eq. 8): q_i = q_min + (q_max - q_min) rand (count, n)."""
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


def check_voxel(voxel: float, what: str = "voxel size") -> float:
    """A voxel edge [m]: finite and > 0."""
    if not (isinstance(voxel, (int, float, np.floating, np.integer)) and np.isfinite(voxel) and voxel > 0):
        raise WorkspaceInputError(f"{what} must be a finite number > 0 [m], got {voxel!r}")
    return float(voxel)


def check_points(points: np.ndarray, what: str = "points") -> np.ndarray:
    """A finite (N, 3) float array."""
    array = np.asarray(points, dtype=float)
    if array.ndim != 2 or array.shape[1] != 3 or not np.all(np.isfinite(array)):
        raise WorkspaceInputError(f"{what} must be a finite (N, 3) array [m], got shape {array.shape}")
    return array


def voxel_indices(points: np.ndarray, voxel: float) -> np.ndarray:
    """Integer voxel index (N, 3) of each point: floor(point / voxel), voxel edge [m]."""
    return np.floor(check_points(points) / check_voxel(voxel)).astype(np.int64)


def flat_keys(indices: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One int64 key per row of integer indices (N, 3), ordered like the rows (C order).

    Returns:
        (keys (N,), low (3,) the smallest index per axis, span (3,) the index range per axis);
        ``np.unravel_index(keys, span) + low`` gives the indices back.
    """
    low = indices.min(axis=0)
    span = indices.max(axis=0) - low + 1
    if float(np.prod(span.astype(float))) >= 2.0**62:
        raise WorkspaceInputError(f"the points span {span.tolist()} voxels per axis, too many for 64-bit keys; "
                                  f"use a larger voxel")
    return np.ravel_multi_index(tuple((indices - low).T), tuple(int(n) for n in span)), low, span


def voxel_keys(points: np.ndarray, voxel: float) -> np.ndarray:
    """Integer voxel indices (M, 3) of the occupied voxels of edge ``voxel`` [m], unique, sorted."""
    indices = voxel_indices(points, voxel)
    if indices.shape[0] == 0:
        return np.empty((0, 3), dtype=np.int64)
    keys, low, span = flat_keys(indices)
    return np.column_stack(np.unravel_index(np.unique(keys), tuple(int(n) for n in span))) + low


def voxel_volume(points: np.ndarray, voxel: float) -> float:
    """Occupied-voxel volume [m^3] of a point cloud (N, 3) [m]."""
    return float(len(voxel_keys(points, voxel)) * check_voxel(voxel) ** 3)


def common_volume(first: np.ndarray, second: np.ndarray, voxel: float) -> float:
    """Volume [m^3] of the voxels occupied by both clouds (N1, 3), (N2, 3) [m] (the common workspace of two arms)."""
    a, b = voxel_keys(first, voxel), voxel_keys(second, voxel)
    if len(a) == 0 or len(b) == 0:
        return 0.0
    keys, _, _ = flat_keys(np.vstack([a, b]))
    shared = np.intersect1d(keys[: len(a)], keys[len(a):], assume_unique=True)
    return float(len(shared) * check_voxel(voxel) ** 3)


# ---------------------------------------------------------------------------------------------- dexterity

#: Frame axes that can be the approach direction, and their column in a rotation matrix.
AXES = {"x": 0, "y": 1, "z": 2}


def equal_area_rings(count: int) -> tuple[np.ndarray, np.ndarray]:
    """An equal-area partition of the unit sphere into ``count`` cells, as rings of cells.

    Zonal construction after Leopardi's EQSP: a polar cap of one cell at each pole,
    then collars about one cell side wide (sqrt(4 pi / count)) each holding the
    number of cells that fits its area (rounded with carry-over so the total is
    exact); the collar boundaries are then moved so that every cell has area
    exactly 4 pi / count (by Archimedes, a zone's area is 2 pi times its height in z).

    Returns:
        (z_edges (R+1,) from +1 down to -1, cells per ring (R,)).
    """
    if count == 1:
        return np.array([1.0, -1.0]), np.array([1])
    if count == 2:
        return np.array([1.0, 0.0, -1.0]), np.array([1, 1])
    cap = np.arccos(1.0 - 2.0 / count)  # polar angle of a one-cell cap
    collars = max(1, round(float((np.pi - 2.0 * cap) / np.sqrt(4.0 * np.pi / count))))
    width = (np.pi - 2.0 * cap) / collars
    counts, carry = [1], 0.0
    for k in range(collars):
        ideal = (np.cos(cap + k * width) - np.cos(cap + (k + 1) * width)) * count / 2.0 + carry
        cells = max(1, round(float(ideal)))
        carry = ideal - cells
        counts.append(cells)
    counts[-1] += count - 1 - sum(counts)  # absorbs round-off so that the total is exact
    counts.append(1)
    counts = np.array(counts)
    z_edges = np.concatenate([[1.0], 1.0 - 2.0 * np.cumsum(counts) / count])
    z_edges[-1] = -1.0
    return z_edges, counts


@dataclass(frozen=True)
class OrientationGrid:
    """Cells of the orientation space SO(3): equal-area cells of the approach direction x bins of the roll.

    The approach direction (one axis of the frame, a point of the unit sphere)
    falls in one of ``directions`` equal-area cells (`equal_area_rings`); the roll
    is the angle of the next frame axis (y after x, z after y, x after z) about the
    centre direction of that cell, measured from a fixed tangent basis of the cell,
    cut into ``roll_bins`` equal bins. The uniform (Haar) measure of SO(3) is the
    uniform measure of the approach direction times the uniform measure of the
    roll, so the cells have equal volume up to the tilt of the direction inside its
    cell (about 2 % for 100 cells). ``roll_bins=1`` measures approach directions only.

    Attributes:
        directions: number of approach-direction cells (>= 1). Default 100: cells about 20 deg across.
        roll_bins: number of roll bins (>= 1). Default 18: 20 deg each, matching the direction cells.
        approach: frame axis taken as the approach direction, "x", "y" or "z".
    """

    directions: int = 100
    roll_bins: int = 18
    approach: str = "z"
    z_edges: np.ndarray = field(init=False, repr=False, compare=False)  # (R+1,)
    ring_counts: np.ndarray = field(init=False, repr=False, compare=False)  # (R,)
    ring_offsets: np.ndarray = field(init=False, repr=False, compare=False)  # (R,)
    centres: np.ndarray = field(init=False, repr=False, compare=False)  # (directions, 3) unit
    tangents: np.ndarray = field(init=False, repr=False, compare=False)  # (directions, 2, 3) roll basis

    def __post_init__(self) -> None:
        for name in ("directions", "roll_bins"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise WorkspaceInputError(f"OrientationGrid.{name} must be an integer >= 1, got {value!r}")
        if self.approach not in AXES:
            raise WorkspaceInputError(f"approach axis must be one of x, y, z; got {self.approach!r}")
        z_edges, counts = equal_area_rings(int(self.directions))
        offsets = np.concatenate([[0], np.cumsum(counts)[:-1]])
        centres = []
        for ring, cells in enumerate(counts):
            if cells == 1 and ring in (0, len(counts) - 1):  # a polar cap: centred on its pole
                z = 1.0 if ring == 0 else -1.0
            else:
                z = 0.5 * (z_edges[ring] + z_edges[ring + 1])  # halves the ring's area
            longitude = -np.pi + (np.arange(cells) + 0.5) * 2.0 * np.pi / cells
            radius = np.sqrt(max(0.0, 1.0 - z * z))
            centres.append(np.column_stack([radius * np.cos(longitude), radius * np.sin(longitude),
                                            np.full(cells, z)]))
        centres = np.vstack(centres)
        reference = np.where(np.abs(centres[:, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
        first = np.cross(reference, centres)
        first /= np.linalg.norm(first, axis=1, keepdims=True)
        second = np.cross(centres, first)
        object.__setattr__(self, "z_edges", z_edges)
        object.__setattr__(self, "ring_counts", counts)
        object.__setattr__(self, "ring_offsets", offsets)
        object.__setattr__(self, "centres", centres)
        object.__setattr__(self, "tangents", np.stack([first, second], axis=1))

    @property
    def count(self) -> int:
        """Number of orientation cells: directions x roll_bins."""
        return int(self.directions) * int(self.roll_bins)

    def direction_cells(self, directions: np.ndarray) -> np.ndarray:
        """Cell index (N,) in [0, directions) of direction vectors (N, 3) (any non-zero length)."""
        vectors = np.asarray(directions, dtype=float)
        norms = np.linalg.norm(vectors, axis=1)
        z = np.clip(vectors[:, 2] / norms, -1.0, 1.0)
        ring = np.searchsorted(-self.z_edges[1:-1], -z, side="right")
        cells = self.ring_counts[ring]
        fraction = (np.arctan2(vectors[:, 1], vectors[:, 0]) + np.pi) / (2.0 * np.pi)
        return self.ring_offsets[ring] + np.minimum((fraction * cells).astype(np.int64), cells - 1)

    @property
    def axes(self) -> str:
        """The frame axes the cells depend on: the approach axis, then (with roll bins) the one after it."""
        following = "xyz"[(AXES[self.approach] + 1) % 3]
        return self.approach + following if self.roll_bins > 1 else self.approach

    def cells(self, rotations: np.ndarray) -> np.ndarray:
        """Orientation cell index (N,) in [0, count) of frame rotations (N, 3, 3) (columns: frame axes)."""
        rotations = np.asarray(rotations, dtype=float)
        if rotations.ndim != 3 or rotations.shape[1:] != (3, 3) or not np.all(np.isfinite(rotations)):
            raise WorkspaceInputError(f"rotations must be a finite (N, 3, 3) array, got shape {rotations.shape}")
        return self.cells_from_axes(np.stack([rotations[:, :, AXES[axis]] for axis in self.axes], axis=1))

    def cells_from_axes(self, axes: np.ndarray) -> np.ndarray:
        """Orientation cell index (N,) in [0, count) from the frame axes named by `axes`, unit vectors (N, k, 3)."""
        axes = np.asarray(axes, dtype=float)
        if axes.ndim != 3 or axes.shape[1:] != (len(self.axes), 3) or not np.all(np.isfinite(axes)):
            raise WorkspaceInputError(f"axes must be a finite (N, {len(self.axes)}, 3) array of the frame axes "
                                      f"{', '.join(self.axes)}, got shape {axes.shape}")
        bins = int(self.roll_bins)
        out = np.empty(axes.shape[0], dtype=np.int64)
        for start in range(0, axes.shape[0], CHUNK):
            chunk = axes[start:start + CHUNK]
            direction = self.direction_cells(chunk[:, 0])
            if bins == 1:
                out[start:start + CHUNK] = direction
                continue
            following = chunk[:, 1]  # (n, 3), perpendicular to the approach axis
            tangent = self.tangents[direction]  # (n, 2, 3)
            roll = np.arctan2(np.einsum("ij,ij->i", following, tangent[:, 1]),
                              np.einsum("ij,ij->i", following, tangent[:, 0]))
            roll_bin = np.minimum(((roll + np.pi) / (2.0 * np.pi) * bins).astype(np.int64), bins - 1)
            out[start:start + CHUNK] = direction * bins + roll_bin
        return out


@dataclass
class DexterityMap:
    """Dexterity of the occupied voxels: the fraction of the orientation cells reached in each.

    A Monte Carlo estimate from below: it grows with the samples and cannot exceed
    ``samples / cells`` in a voxel, so compare it across sample counts
    (`WorkspaceResult.dexterity_convergence`) before reading it as a property of the arm.
    An arm with fewer than 6 DOF reaches a lower-dimensional set of poses, so its
    dexterity tends to 0 as the cells shrink: that is a finding, not a bug.

    Attributes:
        centres: voxel centres (M, 3) [m].
        samples: samples that fell in each voxel (M,).
        reached: distinct orientation cells reached in each voxel (M,).
        cells: cells of the orientation grid.
        voxel: voxel edge [m].
    """

    centres: np.ndarray
    samples: np.ndarray
    reached: np.ndarray
    cells: int
    voxel: float

    @property
    def dexterity(self) -> np.ndarray:
        """Fraction (M,) in [0, 1] of the orientation cells reached in each voxel."""
        return self.reached / self.cells

    @property
    def mean(self) -> float:
        """Mean dexterity over the occupied voxels (the reachable volume); 0 when there are none."""
        return float(self.dexterity.mean()) if len(self.reached) else 0.0

    def volume(self, threshold: float) -> float:
        """Volume [m^3] of the voxels whose dexterity is >= threshold (the dexterous workspace at that level)."""
        if not (np.isfinite(threshold) and 0.0 <= threshold <= 1.0):
            raise WorkspaceInputError(f"a dexterity threshold must be in [0, 1], got {threshold!r}")
        return float(np.count_nonzero(self.dexterity >= threshold) * self.voxel**3)

    def summary(self, threshold: float = 0.9) -> dict:
        """Mean, max, voxel count, median samples per voxel and the dexterous volume at ``threshold``."""
        return {
            "mean": self.mean,
            "max": float(self.dexterity.max()) if len(self.reached) else 0.0,
            "voxels": len(self.reached),
            "median_samples_per_voxel": float(np.median(self.samples)) if len(self.samples) else 0.0,
            "threshold": float(threshold),
            "dexterous_volume": self.volume(threshold),
        }


def dexterity_map(positions: np.ndarray, cells: np.ndarray, voxel: float, total_cells: int) -> DexterityMap:
    """Dexterity per voxel from sample positions (N, 3) [m] and their orientation cells (N,) in [0, total_cells).

    One int64 key per (voxel, orientation cell) pair; ``np.unique`` counts the distinct pairs per voxel.
    """
    positions = check_points(positions, "positions")
    cells = np.asarray(cells)
    if cells.shape != (positions.shape[0],) or (cells.size and (cells.min() < 0 or cells.max() >= total_cells)):
        raise WorkspaceInputError(f"cells must be one integer in [0, {total_cells}) per position "
                                  f"({positions.shape[0]}), got shape {cells.shape}")
    voxel = check_voxel(voxel)
    if positions.shape[0] == 0:
        empty = np.empty(0, dtype=np.int64)
        return DexterityMap(np.empty((0, 3)), empty, empty, int(total_cells), voxel)
    keys, low, span = flat_keys(voxel_indices(positions, voxel))
    voxels, rank, samples = np.unique(keys, return_inverse=True, return_counts=True)
    pairs = np.unique(rank.ravel().astype(np.int64) * total_cells + cells.astype(np.int64))
    reached = np.bincount(pairs // total_cells, minlength=len(voxels))
    indices = np.column_stack(np.unravel_index(voxels, tuple(int(n) for n in span))) + low
    return DexterityMap((indices + 0.5) * voxel, samples, reached, int(total_cells), voxel)


def dexterity(rotations: np.ndarray, positions: np.ndarray, voxel: float = 0.1,
              grid: OrientationGrid | None = None) -> DexterityMap:
    """Dexterity per voxel of frame poses: rotations (N, 3, 3), positions (N, 3) [m], voxel edge [m]."""
    grid = grid or OrientationGrid()
    return dexterity_map(positions, grid.cells(rotations), voxel, grid.count)


# ---------------------------------------------------------------------------------------------- hull

HULL_KINDS = ("box", "cylinder", "sphere")


@dataclass(frozen=True)
class HullShape:
    """A solid of the vehicle, in the vehicle frame (the frame of `BatchKinematics` points without a base pose).

    Attributes:
        link: the URDF link it belongs to.
        kind: "box", "cylinder" (axis along its local z) or "sphere".
        rotation: its axes in the vehicle frame (3, 3).
        centre: its centre in the vehicle frame (3,) [m].
        size: box edges (3,), cylinder (radius, length) or sphere (radius,) [m].
    """

    link: str
    kind: str
    rotation: np.ndarray
    centre: np.ndarray
    size: np.ndarray

    def __post_init__(self) -> None:
        sizes = {"box": 3, "cylinder": 2, "sphere": 1}
        if self.kind not in sizes:
            raise WorkspaceInputError(f"hull shape kind must be one of {', '.join(HULL_KINDS)}, got {self.kind!r}")
        size = np.asarray(self.size, dtype=float)
        if size.shape != (sizes[self.kind],) or not np.all(np.isfinite(size)) or np.any(size <= 0):
            raise WorkspaceInputError(f"a {self.kind} of link {self.link!r} needs {sizes[self.kind]} positive "
                                      f"size(s) [m], got {self.size!r}")

    def contains(self, points: np.ndarray) -> np.ndarray:
        """Which points (N, 3) [m] lie inside or on the solid: (N,) bool."""
        local = (check_points(points) - self.centre) @ self.rotation
        size = np.asarray(self.size, dtype=float)
        if self.kind == "box":
            return np.all(np.abs(local) <= 0.5 * size, axis=1)
        if self.kind == "cylinder":
            return (local[:, 0] ** 2 + local[:, 1] ** 2 <= size[0] ** 2) & (np.abs(local[:, 2]) <= 0.5 * size[1])
        return np.einsum("ij,ij->i", local, local) <= size[0] ** 2

    @property
    def volume(self) -> float:
        """Volume of the solid [m^3]."""
        size = np.asarray(self.size, dtype=float)
        if self.kind == "box":
            return float(np.prod(size))
        if self.kind == "cylinder":
            return float(np.pi * size[0] ** 2 * size[1])
        return float(4.0 / 3.0 * np.pi * size[0] ** 3)

    def outline(self) -> np.ndarray:
        """A polyline (K, 3) [m] of the solid's edges in the vehicle frame, NaN rows between pieces (for figures)."""
        size = np.asarray(self.size, dtype=float)
        gap = np.full((1, 3), np.nan)
        if self.kind == "box":
            corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * 0.5 * size
            edges = [(0, 1), (2, 3), (4, 5), (6, 7), (0, 2), (1, 3), (4, 6), (5, 7), (0, 4), (1, 5), (2, 6), (3, 7)]
            pieces = [corners[list(edge)] for edge in edges]
        else:
            angle = np.linspace(0.0, 2.0 * np.pi, 49)
            circle = np.column_stack([np.cos(angle), np.sin(angle), np.zeros_like(angle)]) * size[0]
            if self.kind == "cylinder":
                half = np.array([0.0, 0.0, 0.5 * size[1]])
                pieces = [circle + half, circle - half] + [np.array([p + half, p - half]) for p in circle[:-1:12]]
            else:
                swap = [[0, 2, 1], [2, 1, 0]]
                pieces = [circle, circle[:, swap[0]], circle[:, swap[1]]]
        local = np.vstack([row for piece in pieces for row in (piece, gap)])
        return local @ self.rotation.T + self.centre


def vehicle_links(robot: Robot) -> list[str]:
    """Links rigidly attached to the vehicle joint (the root links for a fixed base), vehicle link first."""
    root = 1 if robot.base_type != "fixed" else 0
    return [frame.name for frame in robot.model.frames
            if frame.type == pin.FrameType.BODY and frame.parentJoint == root]


def hull_shapes(robot: Robot, links: Sequence[str] | None = None, element: str = "auto") -> list[HullShape]:
    """The vehicle's solids (box, cylinder, sphere) read from the model's URDF, in the vehicle frame.

    Args:
        robot: a Robot loaded from URDF/xacro (``robot.urdf`` is its text).
        links: links whose geometry makes the hull; default: the vehicle link (the
            link of the vehicle joint; the root link for a fixed base). Each must be
            rigidly attached to the vehicle (see `vehicle_links`).
        element: "collision", "visual", or "auto" (collision geometry, else visual).

    Returns:
        The solids; meshes are skipped with a warning.

    Raises:
        WorkspaceInputError: no URDF text, a link not on the vehicle, bad ``element``, no usable solid.
    """
    if element not in ("auto", "collision", "visual"):
        raise WorkspaceInputError(f"element must be 'auto', 'collision' or 'visual', got {element!r}")
    if robot.urdf is None:
        raise WorkspaceInputError(f"{robot.name!r} has no URDF text (a composed model), so its hull cannot be read; "
                                  f"pass HullShape objects instead")
    attached = vehicle_links(robot)
    links = list(links) if links is not None else attached[:1]
    unknown = [name for name in links if name not in attached]
    if unknown or not links:
        raise WorkspaceInputError(f"hull links must be rigidly attached to the vehicle; got {unknown or links}, "
                                  f"valid: {', '.join(attached)}")
    elements = {link.get("name"): link for link in ET.fromstring(robot.urdf).iter("link")}
    kinds = ("collision", "visual") if element == "auto" else (element,)
    for kind in kinds:
        shapes = []
        for name in links:
            placement = robot.model.frames[robot.model.getFrameId(name, pin.FrameType.BODY)].placement
            for item in elements[name].findall(kind):
                shape = _urdf_shape(name, item, placement)
                if shape is not None:
                    shapes.append(shape)
        if shapes:
            return shapes
    raise WorkspaceInputError(f"no box, cylinder or sphere {' or '.join(kinds)} geometry on link(s) "
                              f"{', '.join(links)} of {robot.name!r}; hull removal needs one")


def _urdf_shape(link: str, item: ET.Element, placement: pin.SE3) -> HullShape | None:
    """The solid of one URDF <collision>/<visual> element, in the frame of the vehicle joint."""
    def numbers(element: ET.Element | None, name: str, default: str) -> np.ndarray:
        text = element.get(name, default) if element is not None else default
        try:
            return np.array([float(word) for word in text.split()])
        except ValueError:
            raise WorkspaceInputError(f"hull of link {link!r}: {name}={text!r} is not a list of numbers") from None

    origin = item.find("origin")
    xyz, rpy = numbers(origin, "xyz", "0 0 0"), numbers(origin, "rpy", "0 0 0")
    if xyz.shape != (3,) or rpy.shape != (3,):
        raise WorkspaceInputError(f"hull of link {link!r}: an origin needs 3 numbers in xyz and in rpy")
    pose = placement * pin.SE3(pin.rpy.rpyToMatrix(*rpy), xyz)
    geometry = item.find("geometry")
    solid = next(iter(geometry), None) if geometry is not None else None
    if solid is None:
        return None
    if solid.tag == "box":
        size = numbers(solid, "size", "")
    elif solid.tag == "cylinder":
        size = np.concatenate([numbers(solid, "radius", "nan"), numbers(solid, "length", "nan")])
    elif solid.tag == "sphere":
        size = numbers(solid, "radius", "nan")
    else:
        warnings.warn(f"hull of link {link!r}: a <{solid.tag}> is not used (only box, cylinder, sphere)", stacklevel=3)
        return None
    return HullShape(link, solid.tag, np.array(pose.rotation), np.array(pose.translation), size)


def outside_hull(points: np.ndarray, hull: HullShape | Sequence[HullShape]) -> np.ndarray:
    """Which points (N, 3) [m], in the vehicle frame, lie outside every solid of the hull: (N,) bool."""
    shapes = [hull] if isinstance(hull, HullShape) else list(hull)
    points = check_points(points)
    inside = np.zeros(points.shape[0], dtype=bool)
    for shape in shapes:
        inside |= shape.contains(points)
    return ~inside


# ---------------------------------------------------------------------------------------------- Monte Carlo


@dataclass
class WorkspaceResult:
    """Monte Carlo workspace of one or more frames, points in the vehicle frame.

    Attributes:
        frames: frame names; samples: samples per frame.
        joints: sampled joint values per frame (N, n_f); positions: (N, 3) per frame [m].
        volume: occupied-voxel volume per frame [m^3]; common_volume: shared by the first two frames (or None).
        voxel: voxel edge [m]; samples_per_second: samples per second of batched FK (with the
            orientation binning when dexterity is computed).
        convergence: per frame, [(samples, volume)] at N/8, N/4, N/2, N.
        hull: the vehicle solids removed (None: not removed).
        outside_hull: per frame, (N,) True for the samples outside the hull (None: not removed).
        volume_outside_hull: per frame, occupied-voxel volume of the samples outside the hull [m^3].
        common_volume_outside_hull: the same for the common workspace [m^3].
        orientation_grid: the orientation cells of the dexterity (None: not computed).
        dexterity: per frame, the dexterity per voxel (of the samples outside the hull if removed).
        dexterity_convergence: per frame, [(samples, mean dexterity)] at N/4, N/2, N.
    """

    frames: list[str]
    samples: int
    joints: dict[str, np.ndarray]
    positions: dict[str, np.ndarray]
    volume: dict[str, float]
    common_volume: float | None
    voxel: float
    samples_per_second: float
    convergence: dict[str, list[tuple[int, float]]]
    hull: list[HullShape] | None = None
    outside_hull: dict[str, np.ndarray] | None = None
    volume_outside_hull: dict[str, float] | None = None
    common_volume_outside_hull: float | None = None
    orientation_grid: OrientationGrid | None = None
    dexterity: dict[str, DexterityMap] | None = None
    dexterity_convergence: dict[str, list[tuple[int, float]]] | None = None

    def cloud(self, frame: str, count: int | None = None) -> np.ndarray:
        """Positions (K, 3) [m] of the first ``count`` samples (default all) of a frame, hull removed if it was."""
        if frame not in self.positions:
            raise WorkspaceInputError(f"no samples of frame {frame!r}; valid: {', '.join(self.frames)}")
        count = self.samples if count is None else count
        if not 1 <= count <= self.samples:
            raise WorkspaceInputError(f"a sample count must be in [1, {self.samples}], got {count}")
        points = self.positions[frame][:count]
        return points if self.outside_hull is None else points[self.outside_hull[frame][:count]]

    def metrics(self, threshold: float = 0.9) -> dict:
        """The numbers of the run as plain JSON types (what ``uvms workspace`` writes to metrics.json)."""
        common = {"common": self.common_volume} if self.common_volume is not None else {}
        metrics = {
            "frames": list(self.frames), "samples": self.samples, "voxel": self.voxel,
            "volume": {**self.volume, **common},
            "volume_convergence": {frame: [[n, v] for n, v in series] for frame, series in self.convergence.items()},
            "samples_per_second": self.samples_per_second,
        }
        if self.hull is not None:
            common = ({"common": self.common_volume_outside_hull}
                      if self.common_volume_outside_hull is not None else {})
            metrics["volume_outside_hull"] = {**self.volume_outside_hull, **common}
            metrics["hull"] = [{"link": shape.link, "kind": shape.kind, "size": shape.size.tolist(),
                                "centre": shape.centre.tolist(), "volume": shape.volume} for shape in self.hull]
            metrics["fraction_inside_hull"] = {frame: 1.0 - float(mask.mean())
                                               for frame, mask in self.outside_hull.items()}
        if self.dexterity is not None:
            grid = self.orientation_grid
            metrics["dexterity"] = {
                "voxel": next(iter(self.dexterity.values())).voxel, "approach": grid.approach,
                "directions": int(grid.directions), "roll_bins": int(grid.roll_bins), "cells": grid.count,
                "frames": {frame: {**dexterity_.summary(threshold),
                                   "convergence": [[n, m] for n, m in self.dexterity_convergence[frame]]}
                           for frame, dexterity_ in self.dexterity.items()},
            }
        return metrics


def monte_carlo(
    robot: Robot,
    frames: Sequence[str],
    samples: int,
    *,
    seed: int | None = 0,
    voxel: float = 0.05,
    progress: bool | None = None,
    remove_hull: bool | Sequence[HullShape] = False,
    dexterity: bool | OrientationGrid = False,
    dexterity_voxel: float = 0.1,
) -> WorkspaceResult:
    """Sample each frame's joints uniformly, compute the poses in batch, measure volumes (and dexterity).

    Args:
        robot: the model; points are in its vehicle frame (the world for a fixed base).
        frames: frame names; the common workspace is that of the first two.
        samples: joint samples per frame (>= 1).
        seed: random seed (one generator for all frames, in order).
        voxel: voxel edge for the volumes [m].
        progress: progress bar over the samples (None: only on a terminal).
        remove_hull: True to drop the samples inside the vehicle's solids (`hull_shapes`),
            or the solids to use; the volumes and dexterity outside the hull are added.
        dexterity: True (default `OrientationGrid`) or a grid to measure the dexterity per voxel.
        dexterity_voxel: voxel edge for the dexterity [m]; coarser than ``voxel`` because each
            voxel needs many samples to fill its orientation cells.

    Returns:
        The WorkspaceResult.

    Raises:
        WorkspaceInputError: no frames, bad sample count or voxel, no hull geometry;
        FrameNotFound: an unknown frame.
    """
    frames = list(frames)
    if not frames:
        raise WorkspaceInputError("give at least one end-effector frame")
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or samples < 1:
        raise WorkspaceInputError(f"the sample count must be an integer >= 1, got {samples!r}")
    voxel, dexterity_voxel = check_voxel(voxel), check_voxel(dexterity_voxel, "dexterity voxel size")
    hull = None
    if remove_hull is True:
        hull = hull_shapes(robot)
    elif remove_hull is not False and remove_hull is not None:
        hull = [remove_hull] if isinstance(remove_hull, HullShape) else list(remove_hull)
    grid = OrientationGrid() if dexterity is True else (dexterity or None)
    batches = [BatchKinematics(robot, frame) for frame in frames]  # unknown frames fail before any work
    rng = np.random.default_rng(seed)
    joints, positions, volume, convergence = {}, {}, {}, {}
    outside, volume_outside, dexterity_maps, dexterity_convergence = {}, {}, {}, {}
    elapsed = 0.0
    bar = tqdm(total=samples * len(frames), disable=(not progress) if progress is not None else None,
               desc="workspace", unit="sample", unit_scale=True, leave=False)
    try:
        for frame, batch in zip(frames, batches):
            values = batch.sample(samples, rng)
            points = np.empty((samples, 3))
            cells = np.empty(samples, dtype=np.int64) if grid is not None else None
            for start in range(0, samples, CHUNK):
                part = slice(start, min(start + CHUNK, samples))
                started = time.perf_counter()
                if grid is None:
                    points[part] = batch.positions(values[part])
                else:
                    points[part], axes = batch.positions_and_axes(values[part], grid.axes)
                    cells[part] = grid.cells_from_axes(axes)
                elapsed += time.perf_counter() - started
                bar.update(part.stop - part.start)
            joints[frame], positions[frame] = values, points
            volume[frame] = voxel_volume(points, voxel)
            counts = sorted({max(1, samples // 8), max(1, samples // 4), max(1, samples // 2), samples})
            convergence[frame] = [(n, voxel_volume(points[:n], voxel)) for n in counts]
            kept = np.ones(samples, dtype=bool)
            if hull is not None:
                kept = outside[frame] = outside_hull(points, hull)
                volume_outside[frame] = voxel_volume(points[kept], voxel)
            if grid is not None:
                series = []
                for n in sorted({max(1, samples // 4), max(1, samples // 2), samples}):
                    mask = kept[:n]
                    series.append((n, dexterity_map(points[:n][mask], cells[:n][mask], dexterity_voxel, grid.count)))
                dexterity_maps[frame] = series[-1][1]
                dexterity_convergence[frame] = [(n, map_.mean) for n, map_ in series]
    finally:
        bar.close()
    shared = shared_outside = None
    if len(frames) >= 2:
        first, second = frames[:2]
        shared = common_volume(positions[first], positions[second], voxel)
        if hull is not None:
            shared_outside = common_volume(positions[first][outside[first]], positions[second][outside[second]], voxel)
    return WorkspaceResult(
        frames, samples, joints, positions, volume, shared, voxel, samples * len(frames) / max(elapsed, 1e-12),
        convergence, hull=hull, outside_hull=outside if hull is not None else None,
        volume_outside_hull=volume_outside if hull is not None else None,
        common_volume_outside_hull=shared_outside, orientation_grid=grid,
        dexterity=dexterity_maps if grid is not None else None,
        dexterity_convergence=dexterity_convergence if grid is not None else None)
