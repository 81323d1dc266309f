"""The model's geometry for the headless drawings (:mod:`uvms.viz.drawing`, ``uvms view --headless``): its
``<visual>`` geometry as triangle meshes, the vehicle's box and its size.

The geometry is what the browser viewer shows (:func:`uvms.viz.viewer.geometry.visual_geometry`: the URDF's
visuals, mesh URIs resolved as :func:`uvms.load` does, missing or refused meshes left out with a warning). A mesh
is drawn as its own triangles (not its hull: a vehicle's frame stays a frame); a primitive (box, cylinder,
sphere) as the hull of points on its surface (:func:`uvms.viz.collision_shapes.shape_mesh`). matplotlib draws a
few thousand translucent triangles in a second, not the 10^5-10^6 of a public package's hull mesh, so the meshes
share :data:`MAX_DRAWN_TRIANGLES`, each coarsened by vertex clustering (:func:`coarsened`) to its share.

The stick drawing needs no meshes: the vehicle is the box of its link's ``<visual>`` (else ``<collision>``)
(:func:`vehicle_box`), and its frames are drawn at a length that follows the vehicle's size, from the model's
geometry or, without any, from its body's inertia (:func:`body_size`).
"""

from __future__ import annotations

import functools
import warnings

import numpy as np

from ..errors import WorkspaceInputError
from ..robot.robot import Robot
from ..workspace.hull import HullShape, hull_shapes
from .collision_shapes import ShapeMesh, shape_mesh

#: The most triangles of visual meshes a drawing holds (all its meshes together; each panel of a snapshot).
MAX_DRAWN_TRIANGLES = 4000
#: The fewest triangles a mesh is coarsened to (a small part of a large model keeps a recognisable shape).
MIN_MESH_TRIANGLES = 200


def bvh_mesh(geometry: object) -> tuple[np.ndarray, np.ndarray]:
    """(vertices (k, 3) [m], triangles (f, 3)) of a coal BVH model (a mesh as Pinocchio loaded it, scaled)."""
    vertices = np.array(geometry.vertices(), dtype=float).reshape(-1, 3)
    triangles = np.empty((geometry.num_tris, 3), dtype=int)
    for index in range(geometry.num_tris):  # coal gives one triangle per call (0.3 s for 3e5 triangles)
        triangle = geometry.tri_indices(index)
        triangles[index] = (triangle[0], triangle[1], triangle[2])
    return vertices, triangles


def coarsened(vertices: np.ndarray, triangles: np.ndarray, budget: int) -> tuple[np.ndarray, np.ndarray]:
    """The mesh (vertices (k, 3), triangles (f, 3)) with at most ``budget`` triangles: the vertices merged per cell
    of a grid (each cell's vertices become their mean), triangles that collapse or repeat dropped, the grid made
    coarser (by 1.4) until the count fits. A mesh within the budget is returned as it is."""
    if len(triangles) <= budget:
        return vertices, triangles
    lower = vertices.min(axis=0)
    extent = max(float(np.ptp(vertices, axis=0).max()), 1e-9)
    cells = 2.0 * np.sqrt(budget)  # per side of the largest dimension: about budget triangles on a surface
    while True:
        keys = np.floor((vertices - lower) / (extent / cells)).astype(np.int64)
        _, cluster, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
        cluster = cluster.reshape(-1)
        merged = np.column_stack([np.bincount(cluster, vertices[:, k]) for k in range(3)]) / counts[:, None]
        kept = cluster[triangles]
        kept = kept[(kept[:, 0] != kept[:, 1]) & (kept[:, 1] != kept[:, 2]) & (kept[:, 0] != kept[:, 2])]
        _, first = np.unique(np.sort(kept, axis=1), axis=0, return_index=True)
        kept = kept[np.sort(first)]
        if len(kept) <= budget or cells <= 1.0:
            return merged, kept
        cells /= 1.4


def visual_meshes(robot: Robot, budget: int = MAX_DRAWN_TRIANGLES) -> list[ShapeMesh]:
    """The robot's visual geometry as ShapeMeshes in their joints' frames, at most ``budget`` triangles in all
    (module docstring); empty for a model without visuals.

    Warns:
        MissingMeshWarning, GeometryWarning: as :func:`uvms.viz.viewer.geometry.visual_geometry`.
    """
    import coal  # shipped with the pin wheel

    from .viewer.geometry import visual_geometry

    meshes = []
    for item in visual_geometry(robot).geometryObjects:
        if isinstance(item.geometry, coal.BVHModelBase):
            vertices, triangles = bvh_mesh(item.geometry)
            placed = vertices @ item.placement.rotation.T + item.placement.translation
            meshes.append(ShapeMesh(item.name, int(item.parentJoint), placed, triangles))
        else:
            meshes.append(shape_mesh(item))
    total = sum(len(mesh.triangles) for mesh in meshes)
    if total <= budget:
        return meshes
    shares = [max(MIN_MESH_TRIANGLES, int(budget * len(mesh.triangles) / total)) for mesh in meshes]
    return [ShapeMesh(mesh.name, mesh.joint, *coarsened(mesh.vertices, mesh.triangles, share))
            for mesh, share in zip(meshes, shares)]


@functools.lru_cache(maxsize=16)
def vehicle_box(robot: Robot) -> HullShape | None:
    """The vehicle's first box solid from its URDF (`uvms.workspace.hull_shapes`), None without one or for a fixed
    base."""
    if robot.base_type == "fixed" or robot.urdf is None:
        return None
    for element in ("visual", "collision"):  # the visual envelope, not the first of many collision solids
        with warnings.catch_warnings():  # meshes are skipped silently here: the drawing falls back to a triad
            warnings.simplefilter("ignore")
            try:
                shapes = hull_shapes(robot, element=element)
            except WorkspaceInputError:
                continue
        box = next((shape for shape in shapes if shape.kind == "box"), None)
        if box is not None:
            return box
    return None


@functools.lru_cache(maxsize=16)
def body_size(robot: Robot) -> float:
    """The longest side [m] of the uniform solid box with the mass and inertia of the vehicle's body (its links
    joined by fixed joints), 0 for a fixed base or a massless body: the size of a vehicle drawn without geometry."""
    if robot.base_type == "fixed":
        return 0.0
    inertia = robot.model.inertias[1]
    if not inertia.mass > 0:
        return 0.0
    moments = np.linalg.eigvalsh(inertia.inertia)  # principal moments at the centre of mass [kg m^2]
    squares = 6.0 * (moments.sum() - 2.0 * moments) / inertia.mass  # box: I_i = m (b_j^2 + b_k^2) / 12
    return float(np.sqrt(max(float(squares.max()), 0.0)))
