"""Stick drawings (uvms.viz.drawing): what is drawn sits where Pinocchio puts it; snapshots and animations get
written."""

from __future__ import annotations

import os

os.environ.setdefault("MPLBACKEND", "Agg")

import numpy as np
import pytest
from matplotlib import animation
from matplotlib.figure import Figure
from PIL import Image

from uvms.errors import ConfigurationError, UVMSError
from uvms.viz import drawing

from conftest import shipped

#: xiang2019 hull: the xacro defaults hull_length x hull_width x hull_height [m], at the base_link origin.
XIANG_HULL = np.array([2.0, 0.6, 0.5])


def axes(plane: str | None = None):
    figure = Figure()
    return figure.add_subplot(projection="3d") if plane is None else figure.add_subplot()


def drawn_segments(line, dims=3) -> np.ndarray:
    """The (k, 2, dims) segments of a NaN-separated polyline artist."""
    data = np.column_stack(line.get_data_3d() if dims == 3 else line.get_data())
    return data.reshape(-1, 3, dims)[:, :2]


@pytest.mark.parametrize("name", ["xiang2019", "hoang2011"])
def test_one_segment_per_arm_joint_and_dots_at_the_joints(name, rng):
    robot = shipped(name)
    model = robot.model
    for _ in range(3):
        q = robot.random_configuration(rng)
        result = drawing.draw_configuration(axes(), robot, q)
        geometry = result.geometry
        # one segment per joint except the universe and the vehicle joint (whose parent is the world)
        assert len(geometry.segments) == model.njoints - 2 == len(robot.arm_joints)
        assert geometry.joint_names == list(model.names)[1:]
        for name_, dot in zip(geometry.joint_names, geometry.joint_positions):
            np.testing.assert_allclose(dot, robot.fk(q, name_).translation, rtol=0, atol=1e-12)
        for segment, joint in zip(geometry.segments, range(2, model.njoints)):
            parent = model.parents[joint]
            np.testing.assert_allclose(segment[0], geometry.joint_positions[parent - 1], rtol=0, atol=1e-12)
            np.testing.assert_allclose(segment[1], geometry.joint_positions[joint - 1], rtol=0, atol=1e-12)
        np.testing.assert_array_equal(drawn_segments(result.artists["links"]), geometry.segments)
        np.testing.assert_array_equal(np.column_stack(result.artists["joints"].get_data_3d()), geometry.joint_positions)
        for (start, end), frame in zip(geometry.ee_segments, robot.ee_frames):
            pose = robot.fk(q, frame)
            np.testing.assert_allclose(end, pose.translation, rtol=0, atol=1e-12)
            x_axis = drawn_segments(result.artists["triad_x"])[robot.ee_frames.index(frame)]
            np.testing.assert_allclose(x_axis[1] - x_axis[0], geometry.triad_length * pose.rotation[:, 0], atol=1e-12)


def test_xiang2019_vehicle_box_is_the_base_pose_times_the_hull(rng):
    robot = shipped("xiang2019")
    q = robot.random_configuration(rng)
    geometry = drawing.draw_configuration(axes(), robot, q).geometry
    expected = np.array([robot.base_pose(q).act(sign * XIANG_HULL / 2) for sign in drawing.CORNER_SIGNS])
    np.testing.assert_allclose(geometry.box_corners, expected, rtol=0, atol=1e-12)
    edges = geometry.box_edges
    assert edges.shape == (12, 2, 3)
    np.testing.assert_allclose(sorted(np.linalg.norm(edges[:, 1] - edges[:, 0], axis=1)),
                               np.repeat(np.sort(XIANG_HULL), 4))


def test_vehicle_box_is_the_visual_envelope_not_a_collision_solid():
    box = drawing.vehicle_box(shipped("bluerov2_alpha5"))  # 14 collision solids on base_link, one visual box
    np.testing.assert_allclose(box.size, [0.457, 0.575, 0.254], rtol=0, atol=1e-12)
    np.testing.assert_allclose(box.centre, np.zeros(3), atol=1e-12)


def test_vehicle_without_a_box_gets_a_triad(rng):
    robot = shipped("amundsen2018")  # its base link is a cylinder
    q = robot.random_configuration(rng)
    geometry = drawing.draw_configuration(axes(), robot, q).geometry
    assert geometry.box_corners is None and geometry.box_edges.shape == (0, 2, 3)
    assert len(geometry.triads) == len(robot.ee_frames) + 1
    np.testing.assert_allclose(geometry.triads[-1, :, 0], np.tile(robot.base_pose(q).translation, (3, 1)), atol=1e-12)


def test_plane_projection_and_axes_checks(rng):
    robot = shipped("hoang2011")
    q = robot.random_configuration(rng)
    result = drawing.draw_configuration(axes("xy"), robot, q, plane="xy")
    np.testing.assert_array_equal(drawn_segments(result.artists["links"], dims=2), result.geometry.segments[:, :, :2])
    with pytest.raises(UVMSError, match="valid: xy, xz, yz"):
        drawing.draw_configuration(axes("xy"), robot, q, plane="zx")
    with pytest.raises(UVMSError, match="3-D Axes"):
        drawing.draw_configuration(axes("xy"), robot, q)
    with pytest.raises(ConfigurationError, match="shape"):
        drawing.draw_configuration(axes(), robot, q[:-1])


def test_animate_writes_a_gif_with_one_frame_per_configuration(tmp_path, rng):
    robot = shipped("xiang2019")
    configurations = np.array([robot.random_configuration(rng) for _ in range(7)])
    path = drawing.animate(robot, configurations, tmp_path / "motion.gif", fps=10, times=np.arange(7) * 0.5,
                           trail_frame="left_ee", dpi=40, figsize=(4, 4), progress=False)
    with Image.open(path) as image:
        assert image.format == "GIF" and image.n_frames == 7
    assert sorted(os.listdir(tmp_path)) == ["motion.gif"]  # no temporary left behind


def test_animate_rejects_bad_paths_and_inputs(tmp_path, monkeypatch):
    robot = shipped("hoang2011")
    configurations = [robot.neutral()] * 2
    with pytest.raises(UVMSError, match=r"\.gif, \.mp4"):
        drawing.animate(robot, configurations, tmp_path / "motion.avi", progress=False)
    monkeypatch.setattr(animation.FFMpegWriter, "isAvailable", classmethod(lambda cls: False))
    with pytest.raises(UVMSError, match="mp4 needs ffmpeg on PATH"):
        drawing.animate(robot, configurations, tmp_path / "motion.mp4", progress=False)
    with pytest.raises(UVMSError, match="times"):
        drawing.animate(robot, configurations, tmp_path / "motion.gif", times=[0.0], progress=False)
    with pytest.raises(ConfigurationError, match="configuration 1"):
        drawing.animate(robot, [robot.neutral(), np.zeros(robot.nq)], tmp_path / "motion.gif", progress=False)
    assert os.listdir(tmp_path) == []


def test_snapshot_figure_writes_a_png(tmp_path, rng):
    robot = shipped("xiang2019")
    configurations = [robot.neutral(), robot.random_configuration(rng), robot.random_configuration(rng)]
    figure = drawing.snapshot_figure(robot, configurations, titles=["a", "b", "c"], path=tmp_path / "snap.png")
    assert isinstance(figure, Figure) and len(figure.axes) == 3
    assert [ax.name for ax in figure.axes] == ["3d"] * 3
    with Image.open(tmp_path / "snap.png") as image:
        assert image.format == "PNG"
    with pytest.raises(UVMSError, match="one per configuration"):
        drawing.snapshot_figure(robot, configurations, titles=["a"])


def test_snapshot_panels_share_equal_limits(rng):
    robot = shipped("xiang2019")
    figure = drawing.snapshot_figure(robot, [robot.random_configuration(rng) for _ in range(2)], view=(10, 30))
    for ax in figure.axes:
        spans = [np.ptp(ax.get_xlim()), np.ptp(ax.get_ylim()), np.ptp(ax.get_zlim())]
        np.testing.assert_allclose(spans, spans[0])
    np.testing.assert_allclose(figure.axes[0].get_xlim(), figure.axes[1].get_xlim())
