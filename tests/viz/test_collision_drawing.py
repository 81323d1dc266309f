"""The collision overlay of the headless drawing: one translucent collection per collision shape at the drawn
configuration, the closest pair's segment on coal's witness points, obstacles clipped to the Axes; no text on the
shapes (the pairs are named in a legend below each panel, a key explains shapes, pair colours and frame axes); the
docs figure (docs/figures/collision.py) with unique panel letters."""

from __future__ import annotations

import os

os.environ.setdefault("MPLBACKEND", "Agg")

import importlib.util
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import PolyCollection
from matplotlib.colors import same_color
from matplotlib.figure import Figure
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

import uvms
from uvms.model.collision import collision_geometry
from uvms.robot.configuration import Configuration
from uvms.tasks.objectives import Obstacle, SelfCollision
from uvms.viz import drawing
from uvms.viz.collision_drawing import SHAPE_STYLE, CollisionOverlay, clip_polygon
from uvms.viz.collision_shapes import PAIR_COLOURS, geometry_meshes

from conftest import ROOT

FIXTURES = Path(__file__).parents[1] / "fixtures" / "collision"


@pytest.fixture(scope="module")
def robot():
    with pytest.warns(uvms.errors.BaseGuessWarning):
        return uvms.load(FIXTURES / "box_arm.urdf")


@pytest.fixture(scope="module")
def objective(robot):
    return SelfCollision(robot, min=0.02, band=0.05, pairs="all", count=2)


def arm_pose(robot, rng):
    return robot.configuration(base=np.r_[rng.uniform(-0.5, 0.5, 3), rng.uniform(-0.5, 0.5, 3)],
                               arm=rng.uniform(-2.5, 2.5, robot.n_arm))


def collections(figure, kind):
    return [artist for ax in figure.axes for artist in ax.collections if type(artist) is kind]


def drawn_vertices(collection: Poly3DCollection) -> np.ndarray:
    """The vertices (m, 3) of the polygons a Poly3DCollection holds (matplotlib pads shorter polygons)."""
    faces = np.asarray(collection._faces)
    return faces[~np.broadcast_to(np.asarray(collection._invalid_vertices), faces.shape[:2])]


def by_rows(points: np.ndarray) -> np.ndarray:
    """Points (m, 3) sorted by rows (a drawn figure keeps its faces in depth order)."""
    return points[np.lexsort(np.round(points, 9).T[::-1])]


def witness(objective, robot, q):
    """(point1, point2, distance) of the nearest of every pair at q: an oracle over all pairs."""
    everything = objective.distances.evaluate(Configuration(robot, q))
    k = int(np.argmin(everything.distance))
    return everything.point1[k], everything.point2[k], everything.distance[k]


def test_the_collision_toggle_adds_one_translucent_collection_per_shape_at_its_pose(robot, rng, tmp_path):
    q = arm_pose(robot, rng)
    geometry = collision_geometry(robot)
    plain = drawing.snapshot_figure(robot, [q])
    assert collections(plain, Poly3DCollection) == []
    figure = drawing.snapshot_figure(robot, [q, q], overlay=CollisionOverlay(robot), path=tmp_path / "shapes.png")
    shapes = collections(figure, Poly3DCollection)
    assert len(shapes) == 2 * geometry.ngeoms and all(0 < shape.get_alpha() < 1 for shape in shapes)
    data = robot.model.createData()
    pin.forwardKinematics(robot.model, data, q)  # the oracle: Pinocchio's joint placements, one mesh at a time
    for shape, mesh in zip(shapes, geometry_meshes(geometry)):
        expected = [data.oMi[mesh.joint].act(v) for v in mesh.vertices[mesh.triangles].reshape(-1, 3)]
        np.testing.assert_allclose(by_rows(drawn_vertices(shape)), by_rows(np.array(expected)), atol=1e-12)
    assert (tmp_path / "shapes.png").stat().st_size > 0


def test_in_a_plane_each_shape_is_the_outline_of_its_projection(robot, rng):
    q = arm_pose(robot, rng)
    overlay = CollisionOverlay(robot)
    figure = drawing.snapshot_figure(robot, [q], plane="xz", overlay=overlay)
    outlines = collections(figure, PolyCollection)
    faces = overlay.robot_faces(q)
    assert len(outlines) == len(faces)
    for outline, shape in zip(outlines, faces):
        path = outline.get_paths()[0].vertices
        points = shape.reshape(-1, 3)[:, [0, 2]]
        for axis in range(2):  # the outline spans the projected shape exactly
            assert path[:, axis].min() == pytest.approx(points[:, axis].min(), abs=1e-12)
            assert path[:, axis].max() == pytest.approx(points[:, axis].max(), abs=1e-12)


def test_the_marked_segment_joins_coals_witness_points_at_each_drawn_configuration(robot, objective, rng):
    overlay = CollisionOverlay(robot, shapes=False, objectives=[objective])
    figure = Figure()
    ax = figure.add_subplot(projection="3d")
    q = arm_pose(robot, rng)
    marks = overlay.draw(ax, q)
    for k in range(4):
        point1, point2, distance = witness(objective, robot, q)
        x, y, z = marks.pairs[0].get_data_3d()
        np.testing.assert_allclose(np.column_stack([x, y, z]), [point1, point2], atol=1e-9)
        expected = "tab:red" if distance < 0.02 else "tab:orange" if distance < 0.07 else "tab:green"
        assert marks.pairs[0].get_color() == expected
        (label,) = marks.legend.get_texts()  # the legend below the panel follows the frame
        assert f"{1000 * distance:.1f} mm" in label.get_text()
        assert same_color(marks.legend.legend_handles[0].get_color(), expected)
        q = arm_pose(robot, rng)
        overlay.move(marks, q)  # the next animation frame


def test_in_a_plane_the_segment_is_the_projection_of_the_witness_points(robot, objective, rng):
    overlay = CollisionOverlay(robot, shapes=False, objectives=[objective])
    ax = Figure().add_subplot()
    q = arm_pose(robot, rng)
    marks = overlay.draw(ax, q, plane="yz")
    point1, point2, _ = witness(objective, robot, q)
    np.testing.assert_allclose(np.column_stack(marks.pairs[0].get_data()), [point1[1:], point2[1:]], atol=1e-9)


def test_an_animation_with_the_overlay_writes_a_frame_per_configuration(robot, objective, rng, tmp_path):
    from PIL import Image

    qs = [arm_pose(robot, rng) for _ in range(3)]
    path = drawing.animate(robot, qs, tmp_path / "run.gif", overlay=CollisionOverlay(robot, objectives=[objective]))
    assert Image.open(path).n_frames == 3


def test_obstacles_are_clipped_to_the_axes(robot):
    pipe = Obstacle(robot, "cylinder", radius=0.05, length=20.0, position=[0.6, 0.0, 0.0], rpy=[np.pi / 2, 0, 0])
    overlay = CollisionOverlay(robot, objectives=[pipe])
    ax = Figure().add_subplot(projection="3d")
    ax.set_xlim(-1, 1), ax.set_ylim(-0.5, 0.5), ax.set_zlim(-1, 1)
    [drawn] = overlay.draw_obstacles(ax, np.array([[-1.0, -0.5, -1.0], [1.0, 0.5, 1.0]]))
    corners = drawn_vertices(drawn)
    assert corners[:, 1].min() == pytest.approx(-0.5) and corners[:, 1].max() == pytest.approx(0.5)  # 20 m cut to 1
    assert np.all(np.abs(np.hypot(corners[:, 0] - 0.6, corners[:, 2])) <= 0.05 + 1e-6)


def test_clip_polygon_keeps_the_part_inside_the_box():
    square = np.array([[-2.0, -2.0, 0.0], [2.0, -2.0, 0.0], [2.0, 2.0, 0.0], [-2.0, 2.0, 0.0]])
    clipped = clip_polygon(square, np.array([-1.0, 0.0, -1.0]), np.array([1.0, 1.0, 1.0]))
    assert {tuple(point) for point in clipped.tolist()} == {(-1.0, 0.0, 0.0), (1.0, 0.0, 0.0), (1.0, 1.0, 0.0),
                                                           (-1.0, 1.0, 0.0)}
    assert len(clip_polygon(square, np.array([3.0, 3.0, -1.0]), np.array([4.0, 4.0, 1.0]))) == 0


def key(figure) -> dict[str, object]:
    """label -> handle of the figure's key (its one figure-level legend)."""
    (legend,) = figure.legends
    return {text.get_text(): handle for text, handle in zip(legend.get_texts(), legend.legend_handles)}


def assert_no_text_on_the_panels(figure) -> None:
    """No text artist inside any panel; each panel's legend (the closest pairs) lies below it, off its area."""
    canvas = FigureCanvasAgg(figure)
    canvas.draw()
    renderer = canvas.get_renderer()
    for ax in figure.axes:
        assert len(ax.texts) == 0
        if ax.get_legend() is not None:
            box, area = ax.get_legend().get_window_extent(renderer), ax.get_window_extent(renderer)
            assert box.y1 < area.y0 and not box.overlaps(area)


@pytest.mark.parametrize("plane", [None, "xz"])
def test_the_pairs_are_named_below_the_panels_and_a_key_explains_the_drawing(robot, objective, rng, plane):
    q = arm_pose(robot, rng)
    pipe = Obstacle(robot, "cylinder", radius=0.05, length=2.0, position=[0.6, 0.0, 0.0])
    overlay = CollisionOverlay(robot, objectives=[objective, pipe])
    figure = drawing.snapshot_figure(robot, [q, q], plane=plane, overlay=overlay)
    assert_no_text_on_the_panels(figure)
    labels = [[text.get_text() for text in ax.get_legend().get_texts()] for ax in figure.axes]
    assert labels[0][0].startswith("self_collision: ") and labels[0][1].startswith("obstacle(cylinder): ")
    geometry = drawing.configuration_geometry(robot, q)
    entries = {label: handle for handle, label in drawing.legend_entries(geometry) + overlay.legend_entries()}
    assert list(key(figure)) == list(entries)  # the key shows them all, in this order
    triad = entries["frame axes: x red, y green, z blue"]
    assert [line.get_color() for line in triad] == list(drawing.TRIAD_COLOURS) == ["tab:red", "tab:green", "tab:blue"]
    assert same_color(entries["collision shapes"].get_facecolor()[:3], SHAPE_STYLE["facecolor"])
    pair = next(handle for label, handle in entries.items() if label.startswith("closest pair"))
    assert [line.get_color() for line in pair] == list(PAIR_COLOURS)
    assert {"links and joints", "obstacle"} <= set(entries)


def load_docs_figure():
    spec = importlib.util.spec_from_file_location("collision_figure", ROOT / "docs" / "figures" / "collision.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_docs_figure_letters_each_panel_once_and_keys_its_marks(monkeypatch, tmp_path):
    figure_script = load_docs_figure()

    def still(toml, folder, extra):  # instead of the four runs: two steps at a bent-arm configuration
        robot = figure_script.named_model(str(toml))
        q = robot.configuration(base=np.r_[0.0, 0.0, -5.0, 0.0, 0.0, 0.0], arm=np.full(robot.n_arm, 0.4))
        return np.array([0.0, 0.1]), np.stack([q, q])

    drawn = []
    monkeypatch.setattr(figure_script, "run", still)
    monkeypatch.setattr(figure_script, "save_figure", lambda figure, path: drawn.append(figure))
    figure_script.main_figure(tmp_path / "collision.png")
    (figure,) = drawn
    titles = [ax.get_title() for ax in figure.axes]
    letters = [title[:3] for title in titles]
    assert letters == ["(a)", "(b)", "(c)", "(d)", "(e)", "(f)"] and len(set(titles)) == 6
    assert_no_text_on_the_panels(figure)
    entries = key(figure)
    assert {"links and joints", "vehicle box", "frame axes: x red, y green, z blue", "collision shapes",
            "obstacle"} <= set(entries)
    assert any(label.startswith("closest pair") for label in entries)
