"""The collision shapes in the browser viewer (the panel's checkbox toggles viser's visibility of the collision
model) and the closest pair's segment on coal's witness points at the configuration shown."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import uvms
from uvms.model.collision import collision_geometry
from uvms.robot.configuration import Configuration
from uvms.tasks.objectives import SelfCollision
from uvms.viz import viewer
from uvms.viz.collision_shapes import geometry_meshes
from uvms.viz.viewer.collision import COLLISION_COLOUR, viewer_collision_model

FIXTURES = Path(__file__).parents[2] / "fixtures" / "collision"
PORT = 18280


@pytest.fixture(scope="module")
def robot():
    with pytest.warns(uvms.errors.BaseGuessWarning):
        return uvms.load(FIXTURES / "box_arm.urdf")


def test_the_viewers_collision_model_is_the_checked_geometry_as_meshes(robot):
    checked = collision_geometry(robot)
    shown = viewer_collision_model(robot)
    assert [item.name for item in shown.geometryObjects] == [item.name for item in checked.geometryObjects]
    for item, mesh in zip(shown.geometryObjects, geometry_meshes(checked)):
        assert item.parentJoint == mesh.joint and item.placement.isIdentity()
        np.testing.assert_allclose(np.asarray(item.geometry.points()), mesh.vertices, atol=1e-15)
        np.testing.assert_array_equal(item.meshColor, COLLISION_COLOUR)
    without_urdf = uvms.Robot(robot.model, ee=robot.ee_frames)
    assert viewer_collision_model(without_urdf).ngeoms == 0


def test_the_checkbox_shows_the_collision_shapes_where_they_are(robot, rng):
    pytest.importorskip("viser")
    q = robot.configuration(base=np.zeros(6), arm=rng.uniform(-2, 2, robot.n_arm))
    with viewer.Viewer(robot, q, port=PORT) as shown:
        visualizer = shown.visualizer
        assert not shown.collision.shown and shown.collision.checkbox.value is False
        shown.collision.checkbox.value = True  # as the page's click
        assert shown.collision.shown
        data, geometry_data = robot.model.createData(), visualizer.collision_model.createData()
        pin.forwardKinematics(robot.model, data, q)
        pin.updateGeometryPlacements(robot.model, data, visualizer.collision_model, geometry_data)
        for k, item in enumerate(visualizer.collision_model.geometryObjects):
            handle = visualizer.frames[f"{visualizer.collisionRootNodeName}/{item.name}"]
            np.testing.assert_allclose(handle.position, geometry_data.oMg[k].translation, atol=1e-6)
        shown.collision.checkbox.value = False
        assert not shown.collision.shown
    with viewer.Viewer(robot, q, port=PORT, collision=True) as shown:
        assert shown.collision.shown and shown.collision.checkbox.value is True


def test_the_closest_pair_is_marked_at_every_configuration_shown(robot, rng):
    pytest.importorskip("viser")
    objective = SelfCollision(robot, min=0.02, band=0.05, pairs="all", count=2)
    with viewer.Viewer(robot, port=PORT) as shown:
        assert shown.collision.segments is None
        shown.mark_closest([objective])
        for _ in range(3):
            q = robot.configuration(base=np.zeros(6), arm=rng.uniform(-2.5, 2.5, robot.n_arm))
            shown.display(q)
            everything = objective.distances.evaluate(Configuration(robot, q))
            k = int(np.argmin(everything.distance))
            np.testing.assert_allclose(shown.collision.segments.points[0], [everything.point1[k], everything.point2[k]],
                                       atol=1e-6)  # viser keeps float32
        shown.collision.checkbox.value = True
        shown.reload(robot)  # the marks were built on the old model: dropped; the checkbox is kept
        assert shown.closest is None and shown.collision.segments is None and shown.collision.shown
        shown.mark_closest([objective])
        assert shown.collision.segments is not None
        shown.mark_closest([])
        assert shown.collision.segments is None
