"""path.png (uvms.viz.paths): the task's own axes (3-D or a plane), where each path starts and ends, arrows in the
direction of travel, the end effector's thin line on top of the desired path's wide light band, the legend below the
axes (off the data), equal scales and a readable z label in 3-D."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg

from uvms.scenario import run_scenario
from uvms.viz.paths import ARROWS, arrow_segments, path_figure

from conftest import NO_FIGURES, yz_circle


@pytest.fixture(scope="module")
def hoang(tmp_path_factory):
    """2 s of the planar hoang2011 circle: the end effector and the vehicle both move."""
    return run_scenario("hoang2011_w1_euler", out=tmp_path_factory.mktemp("hoang") / "h", progress=False,
                        overrides=[*NO_FIGURES, "simulation.duration=2"])


def lines_by_label(axis) -> dict:
    return {line.get_label(): line for line in axis.lines}


def assert_legend_outside_every_axes(figure) -> None:
    """The figure's legend (one, at figure level) overlaps no Axes' area, in the drawn picture."""
    canvas = FigureCanvasAgg(figure)
    canvas.draw()
    renderer = canvas.get_renderer()
    assert all(axis.get_legend() is None for axis in figure.axes)
    (legend,) = figure.legends
    box = legend.get_window_extent(renderer)
    assert figure.bbox.x0 <= box.x0 and box.x1 <= figure.bbox.x1 and figure.bbox.y0 <= box.y0  # inside the picture
    for axis in figure.axes:
        assert not box.overlaps(axis.get_window_extent(renderer))
        for label in (axis.xaxis.label, axis.yaxis.label):
            assert not box.overlaps(label.get_window_extent(renderer))


def markers_at(axis, marker: str) -> np.ndarray:
    """The points (k, d) drawn with ``marker`` and no connecting line."""
    return np.array([np.ravel(line.get_data()) for line in axis.lines
                     if line.get_marker() == marker and line.get_linestyle() == "None" and len(line.get_xdata()) == 1])


def test_arrows_point_along_the_direction_of_travel():
    angle = np.linspace(0.0, 1.5 * np.pi, 400)
    circle = np.column_stack([np.cos(angle), np.sin(angle)])  # counter-clockwise
    segments = arrow_segments(circle)
    assert len(segments) == ARROWS
    for tail, head in segments:
        tangent = np.array([-tail[1], tail[0]])  # d/d(angle) of (cos, sin)
        step = head - tail
        assert np.dot(step, tangent) / np.linalg.norm(step) > 0.99
        assert np.linalg.norm(step) < 0.05  # a head, not a chord across the loop
    midpoints = [np.arctan2(*tail[::-1]) % (2 * np.pi) for tail, _ in segments]
    assert midpoints == pytest.approx((np.arange(ARROWS) + 0.5) / ARROWS * 1.5 * np.pi, abs=0.02)
    reverse = arrow_segments(circle[::-1])
    assert np.dot(reverse[0][1] - reverse[0][0], segments[-1][1] - segments[-1][0]) < 0
    assert arrow_segments(np.ones((10, 2))) == []


def test_a_planar_path_shows_start_end_direction_and_the_end_effector_above_the_desired_band(hoang):
    result = hoang.simulation
    figure = path_figure(result, "h")
    (axis,) = figure.axes
    assert (axis.get_xlabel(), axis.get_ylabel()) == ("x [m]", "y [m]")
    assert figure.get_suptitle() == "h: paths in the x-y plane"
    lines = lines_by_label(axis)
    desired, tracked, vehicle_line = lines["desired (light band)"], lines["end effector"], lines["vehicle"]
    assert tracked.get_zorder() > desired.get_zorder() and vehicle_line.get_zorder() > desired.get_zorder()
    assert tracked.get_linestyle() == "-" and tracked.get_alpha() is None  # solid and opaque on top
    assert desired.get_linewidth() >= 4 * tracked.get_linewidth() and desired.get_alpha() < 0.5  # a light band below
    np.testing.assert_allclose(np.column_stack(tracked.get_data()), result.ee_position[:, :2], atol=1e-12)
    vehicle = np.array([result.robot.base_pose(q).translation[:2] for q in result.q])
    ee = result.ee_position[:, :2]
    ends, starts = markers_at(axis, "s"), markers_at(axis, "o")
    for path in (ee, vehicle):
        assert np.any(np.all(np.isclose(ends, path[-1]), axis=1))
        assert np.any(np.all(np.isclose(starts, path[0]), axis=1))
    arrows = axis.texts
    assert len(arrows) == 2 * ARROWS  # both move
    for arrow in arrows:
        tail, head = np.array(arrow.xyann), np.array(arrow.xy)
        path = next(p for p in (ee, vehicle) if np.any(np.all(p == tail, axis=1)))
        assert np.flatnonzero(np.all(path == head, axis=1))[0] > np.flatnonzero(np.all(path == tail, axis=1))[0]
    legend = [text.get_text() for text in figure.legends[0].get_texts()]
    assert {"start", "end", "direction of travel", "desired (light band)", "end effector", "vehicle"} <= set(legend)
    assert_legend_outside_every_axes(figure)


def test_a_3d_path_has_equal_scales_and_a_z_label_clear_of_the_ticks(tmp_path):
    result = run_scenario(yz_circle(tmp_path, ["x", "y", "z"]), out=tmp_path / "yz3", progress=False)
    assert result.metrics["max_position_error"] < 1e-6
    assert (tmp_path / "yz3" / "path.png").stat().st_size > 10_000
    figure = path_figure(result.simulation, "yz")
    (axis,) = figure.axes
    assert axis.name == "3d" and "3-D" in figure.get_suptitle()
    assert (axis.get_xlabel(), axis.get_ylabel(), axis.get_zlabel()) == ("x [m]", "y [m]", "z [m]")
    ranges = np.array([np.ptp(axis.get_xlim()), np.ptp(axis.get_ylim()), np.ptp(axis.get_zlim())])
    scale = ranges / axis.get_box_aspect()  # metres per unit of box side
    assert scale == pytest.approx(np.full(3, scale[0]), rel=1e-9)
    canvas = FigureCanvasAgg(figure)
    canvas.draw()
    renderer = canvas.get_renderer()
    for coordinate in (axis.xaxis, axis.yaxis, axis.zaxis):
        label = coordinate.label.get_window_extent(renderer)
        assert figure.bbox.x0 <= label.x0 and label.x1 <= figure.bbox.x1
        assert figure.bbox.y0 <= label.y0 and label.y1 <= figure.bbox.y1
        ticks = [tick.label1.get_window_extent(renderer) for tick in coordinate.majorTicks
                 if tick.label1.get_visible() and tick.label1.get_text()]
        assert ticks and not any(label.overlaps(tick) for tick in ticks)
    assert_legend_outside_every_axes(figure)


def test_a_planar_task_is_drawn_in_its_own_plane(tmp_path):
    result = run_scenario(yz_circle(tmp_path, ["y", "z"]), out=tmp_path / "yz2", progress=False, overrides=NO_FIGURES)
    figure = path_figure(result.simulation, "yz")
    (axis,) = figure.axes
    assert axis.name != "3d"
    assert (axis.get_xlabel(), axis.get_ylabel()) == ("y [m]", "z [m]")
    assert "the y-z plane" in figure.get_suptitle()
