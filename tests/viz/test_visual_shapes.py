"""The model's geometry in headless drawings (uvms.viz.visual_shapes): visual meshes, coarsened to a budget, and
frames drawn at the size of the vehicle."""

from __future__ import annotations

import os

os.environ.setdefault("MPLBACKEND", "Agg")

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

import uvms
from uvms.viz import drawing
from uvms.viz.collision_drawing import CollisionOverlay
from uvms.viz.visual_shapes import MAX_DRAWN_TRIANGLES, body_size, coarsened

from conftest import ROOT

#: A Smilodon-sized vehicle alone: a 2.0 x 1.0 x 0.8 m box mesh 0.1 m ahead of its origin.
ARMLESS = ROOT / "tests" / "fixtures" / "armless" / "vehicle.urdf"


@pytest.fixture(scope="module")
def vehicle() -> uvms.Robot:
    return uvms.load(ARMLESS)


def test_a_vehicle_alone_is_drawn_with_its_mesh_and_frames_of_its_size(vehicle):
    """The headless picture of a vehicle without an arm whose hull is a mesh: the mesh's 12 triangles where the
    URDF puts them, and frames of 8 % (its end effector) and 16 % (the vehicle) of its extent, 2.2 m turned by 0.3
    rad (before: 8 and 16 mm, of the floor of 0.1 m, and no mesh)."""
    overlay = CollisionOverlay(vehicle, shapes=False, visual=True)
    [mesh] = overlay.visuals
    assert len(mesh.triangles) == 12 and overlay.meshes == []
    q = vehicle.configuration(base=[1.0, -2.0, -20.0, 0.0, 0.0, 0.3])
    points = overlay.points(q)
    pose = vehicle.base_pose(q)
    local = (points - pose.translation) @ pose.rotation  # in the vehicle's frame
    np.testing.assert_allclose(local.min(axis=0), [-0.9, -0.5, -0.4], atol=1e-6)
    np.testing.assert_allclose(local.max(axis=0), [1.1, 0.5, 0.4], atol=1e-6)
    figure = drawing.snapshot_figure(vehicle, [q], overlay=overlay)
    FigureCanvasAgg(figure).draw()  # a 3-D collection projects its faces when drawn
    [faces] = [item for item in figure.axes[0].collections if isinstance(item, Poly3DCollection)]
    assert len(faces.get_paths()) == 12
    triad = drawing._first_geometry(vehicle, q, None, overlay)
    assert triad.triad_length == pytest.approx(0.08 * np.ptp(points, axis=0).max(), rel=1e-9)  # 0.176 m turned
    labels = [text.get_text() for text in figure.legends[0].get_texts()]
    assert "visual meshes" in labels


def test_frames_follow_the_vehicles_size_not_its_distance_from_the_world_origin(vehicle):
    """Without any drawn geometry the frames take the size of the box of the vehicle's inertia (2.0 m); 20 m below
    the world origin they are as long as at it (before: 8 % of the 20 m to the world origin)."""
    assert body_size(vehicle) == pytest.approx(2.0, rel=1e-6)
    at_origin = drawing.configuration_geometry(vehicle, vehicle.neutral())
    deep = drawing.configuration_geometry(vehicle, vehicle.configuration(base=[0.0, 0.0, -20.0, 0.0, 0.0, 0.0]))
    assert at_origin.triad_length == pytest.approx(0.16, rel=1e-6) == deep.triad_length


def test_a_large_mesh_is_coarsened_to_its_budget_keeping_its_extent():
    """A hull of revolution of 99,600 triangles drawn with at most 4,000; its box kept to a grid cell."""
    x = np.linspace(-1.5, 1.5, 250)
    radius = 0.35 * np.clip(1 - (x / 1.5) ** 2, 0, 1) ** 0.3
    angle = np.linspace(0, 2 * np.pi, 200, endpoint=False)
    vertices = np.column_stack([np.repeat(x, 200), np.outer(radius, np.cos(angle)).ravel(),
                                np.outer(radius, np.sin(angle)).ravel()])
    i, j = np.meshgrid(np.arange(249), np.arange(200), indexing="ij")
    corner = (i * 200 + j).ravel()
    right, up = (i * 200 + (j + 1) % 200).ravel(), ((i + 1) * 200 + j).ravel()
    diagonal = ((i + 1) * 200 + (j + 1) % 200).ravel()
    triangles = np.concatenate([np.column_stack([corner, up, right]), np.column_stack([right, up, diagonal])])
    assert len(triangles) == 99_600
    merged, kept = coarsened(vertices, triangles, MAX_DRAWN_TRIANGLES)
    assert 1000 < len(kept) <= MAX_DRAWN_TRIANGLES
    cell = 3.0 / (2.0 * np.sqrt(MAX_DRAWN_TRIANGLES))
    np.testing.assert_allclose(merged.min(axis=0), vertices.min(axis=0), atol=2 * cell)
    np.testing.assert_allclose(merged.max(axis=0), vertices.max(axis=0), atol=2 * cell)
    small = triangles[:100]
    assert coarsened(vertices, small, 200)[1] is small  # within the budget: as it is
