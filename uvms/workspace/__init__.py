"""Monte Carlo workspace: uniform joint samples (xiang2019 eq. 8), batched forward kinematics, voxel volume,
dexterity per voxel and removal of the vehicle hull.

The batched forward kinematics is built from the Pinocchio model, not from a
formula: for every joint on the path to the frame it takes Pinocchio's joint
placement and motion subspace S (a revolute joint turns about S's angular
part, a prismatic one slides along its linear part) and composes the poses of
all samples at once with numpy.

`monte_carlo` streams: it draws the joint samples of each frame in chunks from one
seeded generator (the same numbers as one big draw, so the result does not depend on
the chunk size) and keeps only the occupied voxels, the (voxel, orientation cell) pairs
of the dexterity and the first `POINTS_KEPT` samples, so memory is bounded whatever the
sample count.

Volumes count occupied cubic voxels. Dexterity (xiang2019 defines the dexterous
workspace, "points an end effector can reach in any orientation", but does not
compute it) is measured per voxel as the fraction of the cells of SO(3) that the
samples falling in the voxel reach; see `OrientationGrid` and `dexterity_map`.
Points are in the vehicle frame (the frame of the vehicle joint; the world for a
fixed base), so the vehicle's own hull, read from the URDF, can be cut out
(`hull_shapes`, `outside_hull`).

Modules: ``batch`` (batched forward kinematics), ``voxels`` (volumes, streamed `VoxelOccupancy`),
``dexterity`` (orientation cells per voxel, streamed `DexterityAccumulator`), ``hull`` (the vehicle's
solids), ``montecarlo`` (streamed sampling and results), ``convergence`` (whether a volume has converged:
its change over the last doubling of the samples against a tolerance).
"""

from ..errors import WorkspaceInputError
from .batch import CHUNK, BatchKinematics, JointStep, axis_rotations, rotate_points
from .convergence import CONVERGENCE_TOLERANCE, VolumeConvergence, volume_convergence
from .dexterity import (
    DexterityAccumulator,
    DexterityMap,
    OrientationGrid,
    dexterity_map,
    equal_area_rings,
    pose_dexterity,
)
from .hull import HullShape, hull_shapes, outside_hull, vehicle_links
from .montecarlo import POINTS_KEPT, WorkspaceResult, monte_carlo, parse_sample_count
from .voxels import VoxelOccupancy, common_volume, voxel_indices, voxel_keys, voxel_volume

__all__ = [
    "CHUNK",
    "CONVERGENCE_TOLERANCE",
    "POINTS_KEPT",
    "BatchKinematics",
    "DexterityAccumulator",
    "DexterityMap",
    "HullShape",
    "JointStep",
    "OrientationGrid",
    "VolumeConvergence",
    "VoxelOccupancy",
    "WorkspaceInputError",
    "WorkspaceResult",
    "axis_rotations",
    "common_volume",
    "pose_dexterity",
    "dexterity_map",
    "equal_area_rings",
    "hull_shapes",
    "monte_carlo",
    "outside_hull",
    "parse_sample_count",
    "rotate_points",
    "vehicle_links",
    "voxel_indices",
    "voxel_keys",
    "voxel_volume",
    "volume_convergence",
]
