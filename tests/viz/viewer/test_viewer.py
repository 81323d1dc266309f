"""The 3-D viewer (uvms.viz.viewer, optional viser), `uvms view` (live and --headless) and the teach panel (optional
ipywidgets).

The optional packages are not in the `test` extra: tests that need them are skipped without them, and
the missing-package errors are tested by hiding the packages.
"""

from __future__ import annotations

import os

os.environ.setdefault("MPLBACKEND", "Agg")

import socket
import sys
import time

import numpy as np
import pinocchio as pin
import pytest
from PIL import Image

import uvms
from uvms.cli import main
from uvms.viz import viewer
from uvms.viz.viewer import teach

from conftest import MISSING_MESH, shipped

PORT = 18080  # first port tried by the live tests (the next free one is taken when busy)


def hide(monkeypatch, *modules: str) -> None:
    """Make ``import module`` fail as if the package were not installed."""
    for name in modules:
        monkeypatch.setitem(sys.modules, name, None)


def placements(robot, geometry, q):
    data, geometry_data = robot.model.createData(), geometry.createData()
    pin.forwardKinematics(robot.model, data, q)
    pin.updateGeometryPlacements(robot.model, data, geometry, geometry_data)
    return {item.name: geometry_data.oMg[k] for k, item in enumerate(geometry.geometryObjects)}


def cylinder_ends(pose: pin.SE3, shape) -> np.ndarray:
    half = shape.halfLength * pose.rotation[:, 2]
    return np.array([pose.translation - half, pose.translation + half])


# ------------------------------------------------------------------ geometry (no viser needed)
def test_visuals_come_from_the_urdf_and_sit_on_their_links(rng):
    robot = shipped("hoang2011")
    visual, collision = viewer.geometry_models(robot)
    assert visual.ngeoms == robot.urdf.count("<visual") and collision.ngeoms == robot.urdf.count("<collision")
    assert not any(item.name.startswith("skeleton/") for item in visual.geometryObjects)
    q = robot.random_configuration(rng)
    for item, pose in zip(visual.geometryObjects, placements(robot, visual, q).values()):
        expected = robot.fk(q, robot.model.names[item.parentJoint]) * item.placement
        np.testing.assert_allclose(pose.homogeneous, expected.homogeneous, atol=1e-12)


def test_a_composed_robot_is_shown_as_a_skeleton_joining_its_joints(rng):
    composed = uvms.model.mount_arm(shipped("hoang2011"), "z1", placement=[0.3, 0.0, -0.2, 0.0, 0.0, 0.5])
    robot = uvms.Robot(composed.model, ee=composed.ee_frames)  # a model without URDF (mount_arm now writes one)
    assert robot.urdf is None
    visual, _ = viewer.geometry_models(robot)
    model = robot.model
    links = [j for j in range(1, model.njoints) if model.parents[j] > 0
             and np.linalg.norm(model.jointPlacements[j].translation) > 1e-6]
    names = {item.name for item in visual.geometryObjects}
    assert {f"skeleton/joint_{model.names[j]}" for j in range(1, model.njoints)} <= names
    assert {f"skeleton/link_{model.names[j]}" for j in links} <= names
    assert {f"skeleton/ee_tip_{frame}" for frame in robot.ee_frames} <= names
    objects = {item.name: item for item in visual.geometryObjects}
    for _ in range(3):
        q = robot.random_configuration(rng)
        poses = placements(robot, visual, q)
        for j in links:  # each link cylinder runs from the parent joint origin to the joint origin
            name = f"skeleton/link_{model.names[j]}"
            ends = cylinder_ends(poses[name], objects[name].geometry)
            expected = [robot.fk(q, model.names[model.parents[j]]).translation, robot.fk(q, model.names[j]).translation]
            np.testing.assert_allclose(ends, expected, atol=1e-12)
        for frame in robot.ee_frames:
            np.testing.assert_allclose(poses[f"skeleton/ee_tip_{frame}"].translation, robot.fk(q, frame).translation,
                                       atol=1e-12)


def test_mesh_uris_are_resolved_and_missing_meshes_left_out():
    from uvms.model.meshes import resolved_urdf

    panda = uvms.load(uvms.model.example_robot_urdf("panda"), base="fixed")
    xml, missing = resolved_urdf(panda)
    assert not missing and "package://" not in xml and xml.count(".dae") > 0
    with pytest.warns(uvms.errors.MissingMeshWarning):
        robot = uvms.load(MISSING_MESH, base="floating")
    with pytest.warns(uvms.errors.MissingMeshWarning, match="1 mesh file.*not shown.*no ROS package .no_such_pkg."):
        visual, _ = viewer.geometry_models(robot)
    assert [item.geometry.__class__.__name__ for item in visual.geometryObjects] == ["Box"]


def test_missing_viser_gives_the_install_hint(monkeypatch, capsys):
    hide(monkeypatch, "viser")
    with pytest.raises(viewer.ViewerUnavailable, match=r"pip install uvms\[viz\]"):
        viewer.view(shipped("hoang2011"))
    assert issubclass(viewer.ViewerUnavailable, uvms.UVMSError)
    assert main(["view", "hoang2011"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "uvms[viz]" in err and "--headless" in err


# ------------------------------------------------------------------ uvms view --headless (no viser needed)
def write_run(folder, robot, count=6):
    folder.mkdir()
    t = np.linspace(0.0, 1.0, count)
    q = np.array([robot.configuration(base=[0.1 * k, 0.0, 0.1 * k], arm=[1.0, 0.2 * k, 0.0]) for k in range(count)])
    np.savez(folder / "trajectory.npz", t=t, q=q)
    return t, q


def test_view_headless_writes_a_snapshot_and_an_animation(tmp_path, capsys):
    robot = shipped("hoang2011")
    run = tmp_path / "run"
    write_run(run, robot)
    assert main(["view", "hoang2011", "--q", "0", "0", "0", "1", "0.5", "0.2", "--headless",
                 str(tmp_path / "a.png")]) == 0
    assert Image.open(tmp_path / "a.png").size[0] > 100
    assert main(["view", "hoang2011", "--result", str(run), "--headless", str(tmp_path / "b.gif"), "--frames", "4",
                 "--quiet"]) == 0
    assert Image.open(tmp_path / "b.gif").n_frames == 4
    assert main(["view", "hoang2011", "--result", str(run), "--headless", str(tmp_path / "c.png")]) == 0
    assert "wrote" in capsys.readouterr().out


@pytest.mark.parametrize(("argv", "words"), [
    (["view"], "needs the model"),
    (["view", "hoang2011", "--headless", "x.gif"], "needs --result"),
    (["view", "hoang2011", "--q", "1", "2"], "--q takes 7 numbers"),
    (["view", "hoang2011", "--result", "no_such_dir", "--headless", "x.png"], "does not exist"),
    (["view", "bluerov2_alpha5", "--result", "RUN", "--headless", "x.png"], "nq = 12"),
    (["view", "hoang2011", "--frames", "0", "--headless", "x.png"], "--frames"),
])
def test_view_errors_are_one_line(argv, words, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write_run(tmp_path / "RUN", shipped("hoang2011"))
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and words in err


def test_view_q_accepts_q_pose_and_arm_forms():
    from uvms.cli import view_configuration

    robot = shipped("xiang2019")
    q = robot.random_configuration(3)
    pose = teach.vehicle_pose_values(robot, q)
    arm = robot.arm_configuration(q)
    for values in (q, np.concatenate([pose, arm])):
        got = view_configuration(robot, list(values))
        np.testing.assert_allclose(robot.fk(got).homogeneous, robot.fk(q).homogeneous, atol=1e-12)
    np.testing.assert_allclose(view_configuration(robot, list(arm)), robot.configuration(arm=arm))


# ------------------------------------------------------------------ live viewer (needs viser)
def outside_address() -> str | None:
    """A non-loopback address of this machine, if it has one."""
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
            probe.connect(("10.255.255.255", 1))
            address = probe.getsockname()[0]
    except OSError:
        return None
    return None if address.startswith("127.") else address


def accepts(host: str, port: int) -> bool:
    with socket.socket() as client:
        client.settimeout(1.0)
        return client.connect_ex((host, port)) == 0


def test_viewer_binds_to_localhost_shows_q_and_plays(rng):
    pytest.importorskip("viser")
    robot = uvms.model.mount_arm(shipped("hoang2011"), "z1")
    q = robot.random_configuration(rng)
    with viewer.view(robot, q, port=PORT) as shown:
        port = shown.server.get_port()
        assert shown.url == f"http://127.0.0.1:{port}" and accepts("127.0.0.1", port)
        address = outside_address()
        if address is not None:
            assert not accepts(address, port), "the viewer must not listen on other interfaces"
        visualizer = shown.visualizer
        expected = placements(robot, visualizer.visual_model, q)
        for name, pose in expected.items():
            handle = visualizer.frames[f"{visualizer.visualRootNodeName}/{name}"]
            np.testing.assert_allclose(handle.position, pose.translation, atol=1e-6)
        t = np.linspace(0.0, 2.0, 11)
        qs = np.array([robot.random_configuration(rng) for _ in t])
        started = time.perf_counter()
        viewer.play(robot, t, qs, speed=20.0, fps=10.0, viewer=shown, progress=False)
        assert time.perf_counter() - started < 2.0
        np.testing.assert_array_equal(shown.q, qs[-1])
        assert shown.playback.time_slider.value == pytest.approx(2.0)
        with pytest.raises(uvms.UVMSError, match="non-decreasing"):
            shown.play(t[::-1], qs)
    assert not accepts("127.0.0.1", port)


def test_view_command_serves_until_interrupted(monkeypatch, capsys, tmp_path):
    pytest.importorskip("viser")
    import uvms.cli

    def interrupt():
        raise KeyboardInterrupt

    monkeypatch.setattr(uvms.cli.view, "wait_for_interrupt", interrupt)
    run = tmp_path / "run"
    write_run(run, shipped("hoang2011"), count=3)
    assert main(["view", "hoang2011", "--port", str(PORT), "--result", str(run), "--speed", "100", "--quiet"]) == 0
    assert "viewer      http://127.0.0.1:" in capsys.readouterr().out


# ------------------------------------------------------------------ the page: camera, seabed, triads, panel
CONTINUOUS = """<robot name="spinner">
  <link name="base_link"><inertial><mass value="2"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/>
    </inertial><visual><geometry><box size="0.6 0.4 0.3"/></geometry></visual></link>
  <link name="l1"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><origin xyz="0.2 0 0"/><geometry><box size="0.4 0.05 0.05"/></geometry></visual></link>
  <link name="tool"/>
  <joint name="spin" type="continuous"><parent link="base_link"/><child link="l1"/><origin xyz="0.3 0 0"/>
    <axis xyz="0 0 1"/></joint>
  <joint name="tool_joint" type="fixed"><parent link="l1"/><child link="tool"/><origin xyz="0.4 0 0"/></joint>
</robot>"""


def click(button) -> None:
    """Press a viser button as the page does (its callbacks run)."""
    button.value = True


def test_the_panel_has_a_slider_per_pose_coordinate_and_joint_within_its_limits():
    pytest.importorskip("viser")
    robot = shipped("bluerov2_alpha5")
    with viewer.Viewer(robot, port=PORT) as shown:
        sliders = shown.teach.sliders
        assert list(sliders) == [f"base_{axis}" for axis in robot.base.pose_names] + robot.arm_joint_names
        lower, upper = robot.arm_limits
        for name, low, high in zip(robot.arm_joint_names, lower, upper):
            assert (sliders[name].min, sliders[name].max) == (low, high)
        assert (sliders["base_roll"].min, sliders["base_roll"].max) == (-np.pi, np.pi)
        assert (sliders["base_pitch"].min, sliders["base_pitch"].max) == (-np.pi / 2, np.pi / 2)
        assert sliders["base_x"].min < 0 < sliders["base_x"].max
        assert sliders["alpha_axis_a"].label == "alpha_axis_a [m]" and sliders["base_z"].label == "z [m]"
        shown.display(robot.configuration(base=[12.0, 0.0, 0.0, 0.0, 0.0, 0.0]))  # beyond the range: widened
        assert sliders["base_x"].value == 12.0 and sliders["base_x"].max >= 12.0
    spinner = uvms.load(CONTINUOUS, base="floating")
    assert spinner.joint("spin").nq == 2  # continuous: (cos, sin)
    with viewer.Viewer(spinner, port=PORT) as shown:
        assert (shown.teach.sliders["spin"].min, shown.teach.sliders["spin"].max) == (-np.pi, np.pi)
        shown.teach.sliders["spin"].value = 2.5
        np.testing.assert_allclose(shown.q[-2:], [np.cos(2.5), np.sin(2.5)], atol=1e-12)


def test_a_panel_slider_moves_the_robot_and_its_end_effector_triads():
    pytest.importorskip("viser")
    robot = shipped("bluerov2_alpha5")
    start = robot.configuration(base=[0.5, -0.2, -1.0, 0.0, 0.0, 0.3], arm=[1.0, 1.0, 1.0, 1.0, 0.0])
    with viewer.Viewer(robot, start, port=PORT) as shown:
        np.testing.assert_array_equal(shown.q, start)
        assert [shown.teach.sliders[n].value for n in ("base_x", "base_yaw", "alpha_axis_d")] == \
            pytest.approx([0.5, 0.3, 1.0])
        shown.teach.sliders["alpha_axis_d"].value = 2.5
        shown.teach.sliders["base_z"].value = -2.0
        expected = robot.configuration(base=[0.5, -0.2, -2.0, 0.0, 0.0, 0.3], arm=[1.0, 2.5, 1.0, 1.0, 0.0])
        np.testing.assert_allclose(shown.q, expected, atol=1e-12)
        for frame, handle in shown.triads.handles.items():
            pose = robot.fk(expected, frame)
            np.testing.assert_allclose(handle.position, pose.translation, atol=1e-9)
            np.testing.assert_allclose(np.abs(np.dot(handle.wxyz,
                                                     pin.Quaternion(pose.rotation).coeffs()[[3, 0, 1, 2]])),
                                       1.0, atol=1e-9)
            assert f"{pose.translation[2]:+.3f}" in shown.teach.poses.content
        visualizer = shown.visualizer
        for name, pose in placements(robot, visualizer.visual_model, expected).items():
            np.testing.assert_allclose(visualizer.frames[f"{visualizer.visualRootNodeName}/{name}"].position,
                                       pose.translation, atol=1e-6)
        shown.display(start)  # shown from Python: the sliders follow, the robot stays where it is put
        assert shown.teach.sliders["alpha_axis_d"].value == pytest.approx(1.0)
        np.testing.assert_array_equal(shown.q, start)
        shown.teach.sliders["alpha_axis_d"].value = 2.0
        click(shown.teach.reset_button)
        np.testing.assert_allclose(shown.q, start, atol=1e-12)
        assert shown.teach.sliders["alpha_axis_d"].value == pytest.approx(1.0)


@pytest.mark.parametrize("name", ["bluerov2_alpha5", "hoang2011", "xiang2019"])
def test_the_camera_is_framed_on_the_robot_over_a_seabed_below_it(name):
    pytest.importorskip("viser")
    from uvms.viz.viewer.scene import FOV, MIN_ASPECT, bounding_box, box_corners

    robot = shipped(name)
    with viewer.Viewer(robot, port=PORT) as shown:
        lower, upper = bounding_box(robot, shown.visualizer.visual_model, shown.q)
        camera = shown.server.initial_camera
        np.testing.assert_allclose(camera.look_at, (lower + upper) / 2)
        forward = (camera.look_at - camera.position) / np.linalg.norm(camera.look_at - camera.position)
        right = np.cross(forward, [0.0, 0.0, 1.0])
        right /= np.linalg.norm(right)
        up = np.cross(right, forward)
        seen = box_corners(lower, upper) - camera.position
        depth = seen @ forward
        x, y = seen @ right / depth, seen @ up / depth  # tangents of the view angles
        assert np.all(depth > 0)
        assert np.all(np.abs(y) <= np.tan(FOV / 2)) and np.all(np.abs(x) <= MIN_ASPECT * np.tan(FOV / 2))
        # large: the robot's box spans most of the view one way or the other
        assert max(np.ptp(x) / (2 * MIN_ASPECT * np.tan(FOV / 2)), np.ptp(y) / (2 * np.tan(FOV / 2))) > 0.6
        seabed = shown.seabed
        assert seabed.position[2] < lower[2] and lower[2] - seabed.position[2] < 0.1 * np.linalg.norm(upper - lower)
        half = seabed.width / 2
        assert np.all(np.abs(np.array([lower[:2], upper[:2]]) - seabed.position[:2]) < half)


def test_the_time_slider_shows_frame_k_and_play_pause_drive_the_run(rng):
    pytest.importorskip("viser")
    robot = shipped("hoang2011")
    t = np.linspace(0.0, 1.0, 11)
    qs = np.array([robot.configuration(base=[0.2 * k, 0.0, 0.05 * k], arm=[1.0, 0.1 * k, 0.0]) for k in range(11)])
    with viewer.Viewer(robot, port=PORT) as shown:
        assert shown.playback is None
        shown.load(t, qs, speed=0.5)
        playback = shown.playback
        assert (playback.time_slider.min, playback.time_slider.max) == (0.0, 1.0)
        assert playback.speed_input.value == 0.5 and not playback.playing
        np.testing.assert_array_equal(shown.q, qs[0])
        for k in (3, 7, 10):
            playback.time_slider.value = t[k] + 0.01
            np.testing.assert_array_equal(shown.q, qs[k])
            assert shown.teach.sliders["base_x"].value == pytest.approx(0.2 * k)
        # the whole run is framed: the box of every configuration is inside the camera's target box
        from uvms.viz.viewer.scene import bounding_box

        lower, upper = bounding_box(robot, shown.visualizer.visual_model, qs)
        np.testing.assert_allclose(shown.server.initial_camera.look_at, (lower + upper) / 2)
        playback.time_slider.value = 0.0
        click(playback.play_button)  # plays at 0.5 s per second in the background
        time.sleep(0.5)
        assert playback.playing and playback.pause_button.disabled is False
        click(playback.pause_button)
        assert not playback.playing
        paused = playback.time_slider.value
        assert 0.0 < paused < 1.0
        time.sleep(0.2)
        assert playback.time_slider.value == paused  # it stays paused
        playback.start()  # the page's speed, 0.5
        time.sleep(0.2)
        assert playback.playing
        shown.teach.sliders["q1"].value = 0.5  # touching the teach sliders pauses the run
        assert not playback.playing and shown.robot.arm_configuration(shown.q)[0] == pytest.approx(0.5)
        playback.run(speed=50.0, fps=100.0)  # to the end
        np.testing.assert_array_equal(shown.q, qs[-1])
        assert playback.time_slider.value == 1.0 and playback.play_button.disabled is False
        with pytest.raises(uvms.UVMSError, match="speed"):
            shown.load(t, qs, speed=0.0)


# ------------------------------------------------------------------ teach panel
@pytest.mark.parametrize("name", ["hoang2011", "xiang2019"])
def test_teach_state_is_the_forward_kinematics_of_the_slider_values(name, rng):
    robot = shipped(name)
    specs = teach.sliders(robot)
    assert [s.name for s in specs][: robot.n_vehicle] == list(teach.VEHICLE_SLIDERS[robot.base_type])
    lower, upper = robot.arm_limits
    arm_specs = specs[robot.n_vehicle:]
    np.testing.assert_array_equal([s.lower for s in arm_specs], lower)
    np.testing.assert_array_equal([s.upper for s in arm_specs], upper)
    for _ in range(5):
        q = robot.random_configuration(rng)
        values = dict(zip([s.name for s in specs], [*teach.vehicle_pose_values(robot, q), *robot.arm_configuration(q)]))
        got, poses = teach.teach_state(robot, values)
        assert list(poses) == robot.ee_frames
        for frame, pose in poses.items():
            np.testing.assert_allclose(pose.homogeneous, robot.fk(q, frame).homogeneous, atol=1e-12)
            np.testing.assert_allclose(pose.homogeneous, robot.fk(got, frame).homogeneous, atol=0)
    text = teach.format_poses(poses)
    assert text.count("\n") == len(robot.ee_frames) - 1 and "rpy [deg]" in text
    # a partial update keeps the other values of the given q
    joint = robot.arm_joint_names[0]
    moved, _ = teach.teach_state(robot, {joint: 0.3 * lower[0] + 0.7 * upper[0]}, q)
    index = robot.arm_joints[0].idx_q
    assert moved[index] == pytest.approx(0.3 * lower[0] + 0.7 * upper[0])
    np.testing.assert_array_equal(np.delete(moved, index),
                                  np.delete(q, index))
    with pytest.raises(uvms.UVMSError, match="unknown teach value.*valid: base_x"):
        teach.teach_state(robot, {"shoulder": 0.1})
    with pytest.raises(uvms.UVMSError, match="finite"):
        teach.teach_state(robot, {joint: float("nan")})


def test_teach_without_ipywidgets_gives_the_install_hint(monkeypatch):
    hide(monkeypatch, "ipywidgets")
    with pytest.raises(teach.TeachUnavailable, match=r"pip install uvms\[viz\]"):
        teach.teach(shipped("hoang2011"))


def test_teach_panel_updates_on_a_slider_change():
    pytest.importorskip("ipywidgets")
    robot = shipped("hoang2011")
    panel = teach.teach(robot)
    assert set(panel.sliders) == {"base_x", "base_y", "base_yaw", *robot.arm_joint_names}
    for spec in teach.sliders(robot):
        slider = panel.sliders[spec.name]
        assert (slider.min, slider.max, slider.value) == pytest.approx((spec.lower, spec.upper, spec.value))
    before_label, before_picture = panel.poses.value, panel.picture.value
    panel.sliders["q2"].value = 1.0
    panel.sliders["base_x"].value = 2.0
    q, poses = panel.state()
    assert q[0] == pytest.approx(2.0) and robot.arm_configuration(q)[1] == pytest.approx(1.0)
    assert panel.poses.value != before_label and panel.picture.value != before_picture
    assert teach.format_poses(poses) in panel.poses.value
    assert panel.picture.value[:8] == b"\x89PNG\r\n\x1a\n"


def test_reload_shows_the_edited_model_in_place(tmp_path):
    pytest.importorskip("viser")
    import shutil

    model = tmp_path / "uvms.urdf.xacro"
    shutil.copy(uvms.model.resources.shipped_models()["hoang2011"], model)
    robot = uvms.load(model)
    q = robot.configuration(base=[0, 0, 0], arm=[0.3, 0.2, 0.1])
    with viewer.view(robot, q, port=PORT) as shown:
        port, server = shown.server.get_port(), shown.server
        model.write_text(model.read_text().replace('<xacro:arg name="l1" default="0.4"/>',
                                                   '<xacro:arg name="l1" default="0.7"/>'))
        edited = uvms.load(model)
        shown.reload(edited)
        assert shown.server is server and shown.server.get_port() == port  # the same page (and camera)
        np.testing.assert_array_equal(shown.q, q)  # the configuration shown is kept
        visualizer = shown.visualizer
        moved = 0
        for name, pose in placements(edited, visualizer.visual_model, q).items():
            handle = visualizer.frames[f"{visualizer.visualRootNodeName}/{name}"]
            np.testing.assert_allclose(handle.position, pose.translation, atol=1e-6)
            moved += not np.allclose(pose.translation, placements(robot, visualizer.visual_model, q)[name].translation)
        assert moved > 0  # the links beyond link1 moved by the 0.3 m longer link
