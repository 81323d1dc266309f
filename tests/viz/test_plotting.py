"""Figures of a run (uvms.viz.plotting): the desired motion follows the task's axes, errors below the rounding level
lie on a labelled floor, the vehicle's velocities are named in the frame they are in, joints carry their own unit,
every axis says its quantity and unit, legends sit off the data, a tall figure keeps its title above its first panel,
and the workspace cloud shows every arm's points in each projection with readable 3-D ticks."""

from __future__ import annotations

import re
from types import SimpleNamespace

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import to_rgba

from uvms.scenario import run_scenario
from uvms.viz import plotting
from uvms.viz.plotting import (
    CLOUD_COLOURS,
    ROUNDING_LEVEL,
    desired_motion_figure,
    error_figure,
    gjm_tracking_figure,
    joint_trajectory_figure,
    run_figures,
    stacked,
    workspace_figure,
)

from conftest import NO_FIGURES, yz_circle


@pytest.fixture(scope="module")
def yz3(tmp_path_factory):
    """A kinematic bluerov2_alpha5 run (a prismatic jaw) on a 3-D task: a circle in the y-z plane."""
    folder = tmp_path_factory.mktemp("yz3")
    return run_scenario(yz_circle(folder, ["x", "y", "z"]), out=folder / "run", progress=False, overrides=NO_FIGURES)


def ylabels(figure) -> list[str]:
    return [axis.get_ylabel() for axis in figure.axes]


def legends(figure) -> list:
    return list(figure.legends) + [axis.get_legend() for axis in figure.axes if axis.get_legend() is not None]


def assert_legends_off_the_data(figure) -> None:
    """Every legend of the figure (at least one) lies inside the picture and overlaps no Axes' area."""
    canvas = FigureCanvasAgg(figure)
    canvas.draw()
    renderer = canvas.get_renderer()
    assert legends(figure)
    for legend in legends(figure):
        box = legend.get_window_extent(renderer)
        assert figure.bbox.x0 <= box.x0 and box.x1 <= figure.bbox.x1
        assert figure.bbox.y0 <= box.y0 and box.y1 <= figure.bbox.y1
        for axis in figure.axes:
            assert not box.overlaps(axis.get_window_extent(renderer)), legend.get_texts()[0].get_text()


def urdf_joint_types(urdf: str) -> dict[str, str]:
    """name -> type of every <joint> of a URDF text (an oracle independent of Pinocchio)."""
    return dict(re.findall(r'<joint\s+name="([^"]+)"\s+type="([^"]+)"', urdf))


def test_the_desired_motion_shows_the_controlled_axes_only(yz3, tmp_path):
    desired = desired_motion_figure(yz3.simulation, yz3.setup.trajectory, "yz")
    assert ylabels(desired) == ["speed [m/s]", "x_d [m]", "y_d [m]", "z_d [m]"]  # no roll_d, pitch_d, yaw_d
    assert np.ptp(desired.axes[3].lines[0].get_ydata()) == pytest.approx(0.1, rel=1e-6)
    planar = run_scenario(yz_circle(tmp_path, ["y", "z"]), out=tmp_path / "yz2", progress=False, overrides=NO_FIGURES)
    assert ylabels(desired_motion_figure(planar.simulation, planar.setup.trajectory)) == [
        "speed [m/s]", "y_d [m]", "z_d [m]"]
    hoang = run_scenario("hoang2011_w1_euler", out=tmp_path / "h", progress=False,
                         overrides=[*NO_FIGURES, "simulation.duration=2"])
    assert ylabels(desired_motion_figure(hoang.simulation, hoang.setup.trajectory)) == [
        "speed [m/s]", "x_d [m]", "y_d [m]", "yaw_d [rad]"]


def test_errors_below_the_rounding_level_lie_on_a_labelled_floor():
    t = np.linspace(0.0, 1.0, 200)
    rng = np.random.default_rng(3)
    position = 1e-10 * (1 + t)  # above the floor: drawn as it is
    orientation = np.where(rng.random(200) < 0.5, 0.0, 1e-15 * rng.random(200))  # noise and exact zeros
    run = SimpleNamespace(t=t, position_error=position, orientation_error=orientation)
    figure = error_figure(run, "r")
    (axis,) = figure.axes
    lines = {line.get_label(): line for line in axis.lines}
    assert np.array_equal(lines["position error [m]"].get_ydata(), position)
    flat = lines["orientation error [rad]: at rounding level throughout"].get_ydata()
    assert np.all(flat == ROUNDING_LEVEL) and ROUNDING_LEVEL == 1e-12  # one line on the floor, not a noise band
    floor = lines["rounding level (1e-12)"]
    assert set(floor.get_ydata()) == {ROUNDING_LEVEL}
    assert axis.get_ylim()[0] < ROUNDING_LEVEL and axis.get_yscale() == "log"
    legend = [text.get_text() for text in figure.legends[0].get_texts()]
    assert "rounding level (1e-12)" in legend
    assert axis.get_ylabel() == "error [m] or [rad]"
    assert_legends_off_the_data(figure)
    run.orientation_error = np.where(t > 0.5, 1e-3, 0.0)  # a real error is drawn, zeros on the floor
    (axis,) = error_figure(run).axes
    drawn = {line.get_label(): line for line in axis.lines}["orientation error [rad]"].get_ydata()
    assert np.array_equal(drawn, np.maximum(run.orientation_error, ROUNDING_LEVEL))


def test_vehicle_velocities_are_named_in_flu_and_drawn_as_flu(yz3):
    figures = run_figures(yz3.simulation, yz3.setup.trajectory, "yz")
    velocity = figures["vehicle_velocity.png"]
    assert ylabels(velocity) == ["vx [m/s]", "vy [m/s]", "vz [m/s]", "ωx [rad/s]", "ωy [rad/s]", "ωz [rad/s]"]
    assert "FLU" in velocity.get_suptitle()
    twist = yz3.simulation.v[:, :6]  # Pinocchio's v: the body twist in FLU axes
    robot, q, v = yz3.simulation.robot, yz3.simulation.q, yz3.simulation.v
    nu = np.array([robot.nu_frd(q[k], v[k]) for k in range(len(q))])  # FRD: v, w, q, r flip sign
    assert np.ptp(twist[:, 1]) > 1e-4  # the vehicle sways: the flip would show
    for index, axis in enumerate(velocity.axes):
        assert np.array_equal(axis.lines[0].get_ydata(), twist[:, index])
    assert not np.allclose(velocity.axes[1].lines[0].get_ydata(), nu[:, 1])  # not Fossen's v (FRD sway)


def test_joints_carry_the_unit_of_their_type(yz3):
    robot = yz3.simulation.robot
    types = urdf_joint_types(robot.urdf)
    figures = run_figures(yz3.simulation, yz3.setup.trajectory, "yz")
    labels = ylabels(figures["joints.png"])
    assert len(labels) == robot.n_arm and "alpha_axis_a [m]" in labels  # the jaw's push rod slides
    for name, label in zip(robot.arm_joint_names, labels):
        assert label == f"{name} [{'m' if types[name] == 'prismatic' else 'rad'}]"
    samples = SimpleNamespace(t=np.linspace(0, 1, 5), q=np.full((5, 2), 0.01), qd=np.zeros((5, 2)),
                              qdd=np.zeros((5, 2)))
    figure = joint_trajectory_figure(samples, names=["turn", "slide"], units=["rad", "m"])
    top = figure.axes[:2]
    assert [axis.get_ylabel() for axis in top] == ["position [deg]", "position [m]"]
    assert top[0].lines[0].get_ydata()[0] == pytest.approx(np.degrees(0.01))
    assert top[1].lines[0].get_ydata()[0] == 0.01  # metres are not converted to degrees


def title_clearance(figure) -> float:
    """[px] from the top of the first panel (with its tick labels) up to the bottom of the figure's title."""
    canvas = FigureCanvasAgg(figure)
    canvas.draw()
    renderer = canvas.get_renderer()
    title = figure._suptitle.get_window_extent(renderer)
    panel = figure.axes[0].get_tightbbox(renderer)
    return float(title.y0 - panel.y1)


@pytest.mark.parametrize("panels", [1, 4, 10])
def test_a_tall_figure_keeps_its_title_above_the_first_panel(panels):
    t = np.linspace(0.0, 1.0, 50)
    figure = stacked(t, np.outer(t, np.arange(1, panels + 1)) * 1e3, [f"joint{k} [rad]" for k in range(panels)],
                     "xiang2019_grip: arm joints (dotted: limits)")
    assert title_clearance(figure) >= 0.0


UNIT = re.compile(r"^\S.* \[[^\]]+\]$")  # "quantity [unit]"


def test_every_axis_of_a_run_says_its_quantity_and_unit(yz3):
    result = yz3.simulation
    figures = run_figures(result, yz3.setup.trajectory, "yz")
    assert {"errors.png", "path.png", "joints.png", "vehicle.png"} <= set(figures)
    for name, figure in figures.items():
        for axis in figure.axes:
            assert UNIT.match(axis.get_ylabel()), (name, axis.get_ylabel())
        assert UNIT.match(figure.axes[-1].get_xlabel()), name
    position_only = SimpleNamespace(t=result.t, position_error=result.position_error + 1e-9,
                                    orientation_error=np.zeros_like(result.t))
    assert error_figure(position_only).axes[0].get_ylabel() == "position error [m]"


def tracking_run(count: int = 50) -> SimpleNamespace:
    """What gjm_tracking_figure reads of a tracking-controlled run: a 1 m line in x, y, z tracked exactly."""
    t = np.linspace(0.0, 4.0, count)
    position = np.outer(t / 4.0, [1.0, -1.0, 0.5])
    velocity = np.gradient(position, t, axis=0)
    tracking = SimpleNamespace(ee_position=position, desired_position=position, ee_velocity=velocity,
                               desired_velocity=velocity)
    return SimpleNamespace(t=t, tracking=tracking, final_position_error=0.0)


def test_legends_sit_off_the_data():
    t = np.linspace(0.0, 150.0, 300)
    run = SimpleNamespace(t=t, position_error=1e-10 * (2 + np.sin(t / 8)), orientation_error=1e-11 * (2 + np.cos(t)))
    assert_legends_off_the_data(error_figure(run, "r"))
    series = np.column_stack([np.sin(t / 20), np.cos(t / 20)])
    assert_legends_off_the_data(stacked(t, series, ["a [m]", "b [m]"], "frames", dashed=series + 0.01))
    assert_legends_off_the_data(gjm_tracking_figure(tracking_run(), "gjm"))


@pytest.fixture
def drawn(monkeypatch):
    """workspace_figure's figure, kept instead of written."""
    figures = []
    monkeypatch.setattr(plotting.outputs, "save_figure", lambda figure, path, **_: figures.append(figure))
    return figures


def two_arm_clouds(count: int, rng) -> dict[str, np.ndarray]:
    """Two arms' points [m] in the vehicle frame, like xiang2019's: the same x and z ranges, left at y > 0, right
    at y < 0 (their x-z projections coincide)."""
    def cloud(sign: float) -> np.ndarray:
        return np.column_stack([rng.uniform(-0.4, 1.3, count), sign * rng.uniform(-0.4, 1.2, count),
                                rng.uniform(-1.3, -0.3, count)])
    return {"left_ee": cloud(1.0), "right_ee": cloud(-1.0)}


def drawn_colours(axis) -> np.ndarray:
    """The RGB (n, 3) of every point of an Axes' scatter collections, in drawing order."""
    colours = []
    for collection in axis.collections:
        faces = collection.get_facecolors()[:, :3]
        colours.append(np.broadcast_to(faces, (len(collection.get_offsets()), 3)) if len(faces) == 1 else faces)
    return np.concatenate(colours)


def test_the_workspace_projections_show_both_arms_and_the_3d_ticks_stay_apart(drawn, tmp_path, rng):
    count = 4000
    workspace_figure(two_arm_clouds(count, rng), tmp_path / "w.png", title="two arms")
    (figure,) = drawn
    cloud, *planes = figure.axes
    blue, red = (np.array(to_rgba(colour)[:3]) for colour in CLOUD_COLOURS[:2])
    for axis in planes:
        colours = drawn_colours(axis)
        assert len(colours) == 2 * count
        last = colours[-count // 2:]  # drawn last, on top: both arms, not one over the other
        share = np.mean(np.all(np.isclose(last, blue), axis=1))
        assert 0.4 < share < 0.6 and share + np.mean(np.all(np.isclose(last, red), axis=1)) == 1.0
        assert all(0 < collection.get_alpha() < 0.7 for collection in axis.collections)  # translucent
    canvas = FigureCanvasAgg(figure)
    canvas.draw()
    renderer = canvas.get_renderer()
    for coordinate in (cloud.xaxis, cloud.yaxis, cloud.zaxis):
        boxes = [tick.label1.get_window_extent(renderer) for tick in coordinate.get_major_ticks()
                 if tick.label1.get_visible() and tick.label1.get_text()]
        assert len(boxes) >= 2
        assert not any(a.overlaps(b) for k, a in enumerate(boxes) for b in boxes[k + 1:])
    assert_legends_off_the_data(figure)
    assert [text.get_text() for text in figure.legends[0].get_texts()] == ["left_ee", "right_ee"]
