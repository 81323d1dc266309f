"""Collision shapes as meshes (closed-form surface areas and radii) and the closest pair of each objective (coal's
witness points of the nearest pair, recomputed over every pair)."""

from __future__ import annotations

from pathlib import Path

import coal
import numpy as np
import pinocchio as pin
import pytest

import uvms
from uvms.model.collision import collision_geometry
from uvms.robot.configuration import Configuration
from uvms.tasks.objectives import Obstacle, SelfCollision
from uvms.viz.collision_shapes import (
    PAIR_COLOURS,
    RING_POINTS,
    ClosestPairs,
    geometry_meshes,
    obstacle_meshes,
    pair_colour,
    shape_mesh,
)

FIXTURES = Path(__file__).parents[1] / "fixtures" / "collision"


@pytest.fixture(scope="module")
def robot():
    with pytest.warns(uvms.errors.BaseGuessWarning):
        return uvms.load(FIXTURES / "box_arm.urdf")


def area(mesh) -> float:
    """Surface area of a triangle mesh [m^2]."""
    triangles = mesh.vertices[mesh.triangles]
    return float(0.5 * np.linalg.norm(np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0]),
                                      axis=1).sum())


def mesh_of(shape, placement=None):
    return shape_mesh(pin.GeometryObject("s", 0, 0, placement or pin.SE3.Identity(), shape))


def test_a_box_is_its_8_corners_in_12_triangles_with_the_box_area():
    mesh = mesh_of(coal.Box(0.6, 0.4, 0.2))
    assert mesh.vertices.shape == (8, 3) and mesh.triangles.shape == (12, 3)
    np.testing.assert_allclose(np.abs(mesh.vertices), np.tile([0.3, 0.2, 0.1], (8, 1)), atol=1e-15)
    assert area(mesh) == pytest.approx(2 * (0.6 * 0.4 + 0.4 * 0.2 + 0.2 * 0.6), abs=1e-12)


def test_a_cylinder_is_a_prism_on_two_rings_of_its_radius():
    radius, length, n = 0.03, 0.15, RING_POINTS
    mesh = mesh_of(coal.Cylinder(radius, length))
    np.testing.assert_allclose(np.hypot(mesh.vertices[:, 0], mesh.vertices[:, 1]), radius, atol=1e-15)
    np.testing.assert_allclose(np.abs(mesh.vertices[:, 2]), length / 2, atol=1e-15)
    polygon = n / 2 * radius**2 * np.sin(2 * np.pi / n)
    perimeter = 2 * n * radius * np.sin(np.pi / n)
    assert area(mesh) == pytest.approx(2 * polygon + perimeter * length, rel=1e-12)


def test_spheres_and_capsules_have_every_vertex_on_their_surface():
    sphere = mesh_of(coal.Sphere(0.04))
    np.testing.assert_allclose(np.linalg.norm(sphere.vertices, axis=1), 0.04, atol=1e-15)
    capsule = mesh_of(coal.Capsule(0.05, 0.2))
    axis = np.clip(capsule.vertices[:, 2], -0.1, 0.1)  # the nearest point of the capsule's segment
    offsets = capsule.vertices - np.column_stack([np.zeros((len(axis), 2)), axis])
    np.testing.assert_allclose(np.linalg.norm(offsets, axis=1), 0.05, atol=1e-15)
    assert capsule.vertices[:, 2].max() == pytest.approx(0.15) and capsule.vertices[:, 2].min() == pytest.approx(-0.15)


def test_the_placement_and_the_joint_pose_move_the_faces(rng):
    placement = pin.SE3(pin.rpy.rpyToMatrix(*rng.uniform(-1, 1, 3)), rng.uniform(-1, 1, 3))
    joint = pin.SE3(pin.rpy.rpyToMatrix(*rng.uniform(-1, 1, 3)), rng.uniform(-1, 1, 3))
    plain, placed = mesh_of(coal.Box(0.1, 0.2, 0.3)), mesh_of(coal.Box(0.1, 0.2, 0.3), placement)
    expected = np.array([(joint * placement).act(v) for v in plain.vertices])[plain.triangles]
    np.testing.assert_allclose(placed.faces(joint), expected, atol=1e-14)


def test_a_mesh_obstacle_is_its_convex_hull_and_sits_where_placed(robot):
    rock = Obstacle(robot, "mesh", mesh=FIXTURES / "rock.stl", position=[0.6, 0.22, 0.1])
    [mesh] = obstacle_meshes([rock])
    hull = rock.distances.geometry.geometryObjects[int(rock.distances.pairs[0, 0])].geometry
    np.testing.assert_allclose(mesh.vertices, np.asarray(hull.points()) + [0.6, 0.22, 0.1], atol=1e-14)
    assert mesh.joint == 0 and len(mesh.triangles) == hull.num_polygons
    assert obstacle_meshes([SelfCollision(robot, pairs="all")]) == []


def test_every_robot_shape_gets_a_mesh(robot):
    geometry = collision_geometry(robot)
    meshes = geometry_meshes(geometry)
    assert [mesh.name for mesh in meshes] == [item.name for item in geometry.geometryObjects]


def test_the_closest_pair_is_the_nearest_of_every_pair_with_coals_witness_points(robot, rng):
    objective = SelfCollision(robot, min=0.02, band=0.05, pairs="all", count=3)
    closest = ClosestPairs(robot, [objective])
    for _ in range(10):
        q = robot.configuration(base=np.zeros(6), arm=rng.uniform(-2.5, 2.5, robot.n_arm))
        everything = objective.distances.evaluate(Configuration(robot, q))
        nearest = int(np.argmin(everything.distance))
        [pair] = closest.at(q)
        assert pair.links == objective.links[nearest] and pair.distance == pytest.approx(everything.distance[nearest],
                                                                                         abs=1e-9)
        np.testing.assert_allclose(pair.point1, everything.point1[nearest], atol=1e-9)
        np.testing.assert_allclose(pair.point2, everything.point2[nearest], atol=1e-9)
        assert pair.colour == pair_colour(pair.distance, 0.02, 0.05)


@pytest.mark.parametrize("distance, colour", [(-0.01, 0), (0.0199, 0), (0.02, 1), (0.0699, 1), (0.07, 2), (1.0, 2)])
def test_pair_colours_split_at_min_and_min_plus_band(distance, colour):
    assert pair_colour(distance, 0.02, 0.05) == PAIR_COLOURS[colour]
