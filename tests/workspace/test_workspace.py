"""Monte Carlo workspace (uvms.workspace): batched forward kinematics, sampling, volumes, `uvms workspace`."""

from __future__ import annotations

import json
import tracemalloc

import numpy as np
import pinocchio as pin
import pytest

import uvms
from uvms.cli import main
from uvms.workspace import (
    CHUNK,
    BatchKinematics,
    HullShape,
    OrientationGrid,
    VoxelOccupancy,
    WorkspaceInputError,
    common_volume,
    dexterity_map,
    hull_shapes,
    monte_carlo,
    montecarlo,
    outside_hull,
    parse_sample_count,
    voxel_keys,
    voxel_volume,
)

from conftest import shipped, xiang_eq6

INERTIAL = '<inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial>'


def chain_urdf(axes, lengths, ee_xyz="0 0 0", base_xyz="0 0 0", base_geometry=""):
    """A fixed-base serial chain of revolute joints with limits [-pi, pi]: joint k turns about axes[k] and sits
    lengths[k] along the previous link's x (the first one at base_xyz); frame ``ee`` at ee_xyz on the last link."""
    links = [f'<link name="base_link">{base_geometry}</link>']  # massless: the base rule keeps it fixed
    joints, parent = [], "base_link"
    for k, (axis, length) in enumerate(zip(axes, lengths)):
        origin = base_xyz if k == 0 else f"{length} 0 0"
        links.append(f'<link name="l{k}">{INERTIAL}</link>')
        joints.append(f'<joint name="j{k}" type="revolute"><parent link="{parent}"/><child link="l{k}"/>'
                      f'<origin xyz="{origin}"/><axis xyz="{axis}"/>'
                      f'<limit lower="{-np.pi}" upper="{np.pi}" effort="1" velocity="1"/></joint>')
        parent = f"l{k}"
    joints.append(f'<joint name="ee_joint" type="fixed"><parent link="{parent}"/><child link="ee"/>'
                  f'<origin xyz="{ee_xyz}"/></joint>')
    return '<robot name="chain">' + "".join(links) + '<link name="ee"/>' + "".join(joints) + "</robot>"


def yaw_rotations(angles):
    """Rotations Rz(angle) (N, 3, 3)."""
    c, s, zero, one = np.cos(angles), np.sin(angles), np.zeros_like(angles), np.ones_like(angles)
    return np.stack([np.stack([c, -s, zero], -1), np.stack([s, c, zero], -1), np.stack([zero, zero, one], -1)], 1)


def uniform_rotations(count, rng):
    """Haar-uniform rotations (N, 3, 3) from normalized Gaussian quaternions (w, x, y, z)."""
    w, x, y, z = rng.normal(size=(count, 4)).T
    norm = np.sqrt(w * w + x * x + y * y + z * z)
    w, x, y, z = w / norm, x / norm, y / norm, z / norm
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
    ], 1)


def arm_vector(robot, batch, values):
    arm = np.zeros(robot.n_arm)
    names = robot.arm_joint_names
    for column, name in enumerate(batch.joint_names):
        arm[names.index(name)] = values[column]
    return arm


@pytest.mark.parametrize(("name", "frame"), [("xiang2019", "left_ee"), ("xiang2019", "right_ee"),
                                             ("bluerov2_alpha5", "alpha_push_rod_link"), ("amundsen2018", "ee")])
def test_batched_fk_equals_robot_fk(name, frame, rng):
    robot = shipped(name)
    batch = BatchKinematics(robot, frame)
    values = batch.sample(300, rng)
    base = pin.SE3(pin.rpy.rpyToMatrix(0.1, -0.2, 0.3), np.array([1.0, -2.0, 0.5]))
    rotations, positions = batch.poses(values, base)
    only_positions = batch.positions(values, base)
    with_axes, axes = batch.positions_and_axes(values, "zx", base)
    assert np.allclose(with_axes, positions, atol=1e-12)
    assert np.allclose(axes, rotations[:, :, [2, 0]].transpose(0, 2, 1), atol=1e-12)
    for k in range(0, 300, 3):
        expected = robot.fk(robot.configuration(base=base, arm=arm_vector(robot, batch, values[k])), frame)
        assert np.allclose(positions[k], expected.translation, atol=1e-12)
        assert np.allclose(only_positions[k], expected.translation, atol=1e-12)
        assert np.allclose(rotations[k], expected.rotation, atol=1e-12)


OBLIQUE_CHAIN = ('<robot name="oblique"><link name="base_link"/>'
                 + "".join(f'<link name="l{k}">{INERTIAL}</link>' for k in range(4)) + '<link name="ee"/>'
                 '<joint name="j0" type="revolute"><parent link="base_link"/><child link="l0"/>'
                 '<origin xyz="0.1 -0.2 0.3" rpy="0.3 -0.7 1.1"/>'
                 '<axis xyz="0.30058671670520054 -0.5009778611753343 0.8115841351040415"/>'
                 '<limit lower="-3" upper="3" effort="1" velocity="1"/></joint>'
                 '<joint name="j1" type="prismatic"><parent link="l0"/><child link="l1"/>'
                 '<origin xyz="0.4 0 0" rpy="1.2 0 0"/><axis xyz="0.6 0.8 0"/>'
                 '<limit lower="-0.5" upper="0.7" effort="1" velocity="1"/></joint>'
                 '<joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>'
                 '<origin xyz="0 0.25 -0.1" rpy="0 0 -0.4"/><axis xyz="0 -1 0"/>'
                 '<limit lower="-2" upper="2.5" effort="1" velocity="1"/></joint>'
                 '<joint name="j3" type="revolute"><parent link="l2"/><child link="l3"/>'
                 '<origin xyz="0.2 0.1 0" rpy="-0.5 0.2 0.9"/>'
                 '<axis xyz="0.5773502691896258 0.5773502691896258 0.5773502691896258"/>'
                 '<limit lower="-3" upper="3" effort="1" velocity="1"/></joint>'
                 '<joint name="ee_joint" type="fixed"><parent link="l3"/><child link="ee"/>'
                 '<origin xyz="0.05 -0.03 0.12" rpy="0.1 0.2 0.3"/></joint></robot>')


def test_batched_fk_equals_pinocchio_on_oblique_axes_and_a_prismatic_joint(tmp_path, rng):
    """Rodrigues about oblique axes, a prismatic joint, rotated joint origins: against pin.forwardKinematics."""
    path = tmp_path / "oblique.urdf"
    path.write_text(OBLIQUE_CHAIN)
    robot = uvms.load(str(path), base="fixed")
    batch = BatchKinematics(robot, "ee")
    values = batch.sample(200, rng)
    rotations, positions = batch.poses(values)
    only_positions = batch.positions(values)
    _, axes = batch.positions_and_axes(values, "yz")
    model, data, frame = robot.model, robot.model.createData(), robot.model.getFrameId("ee")
    for k in range(len(values)):
        q = np.zeros(model.nq)
        for column, name in enumerate(batch.joint_names):
            q[model.joints[model.getJointId(name)].idx_q] = values[k, column]
        pin.forwardKinematics(model, data, q)
        expected = pin.updateFramePlacement(model, data, frame)
        assert np.allclose(positions[k], expected.translation, atol=1e-12, rtol=0)
        assert np.allclose(only_positions[k], expected.translation, atol=1e-12, rtol=0)
        assert np.allclose(rotations[k], expected.rotation, atol=1e-12, rtol=0)
        assert np.allclose(axes[k], expected.rotation[:, 1:].T, atol=1e-12, rtol=0)
    assert np.ptp(positions, axis=0).min() > 0.1  # the samples really move the frame


def test_batched_fk_equals_xiang2019_eq7(rng):
    robot = shipped("xiang2019")
    batch = BatchKinematics(robot, "left_ee")
    values = batch.sample(5000, rng)
    positions = batch.positions(values)
    base = robot.fk(robot.neutral(), "left_base")
    relative = (positions - base.translation) @ base.rotation  # into D-H frame 0
    expected = np.array([xiang_eq6(theta).translation for theta in values])
    assert np.max(np.abs(relative - expected)) <= 1e-12


def test_samples_are_uniform_inside_the_limits(rng):
    batch = BatchKinematics(shipped("xiang2019"), "right_ee")
    values = batch.sample(20000, rng)
    assert np.all(values >= batch.lower) and np.all(values <= batch.upper)
    assert batch.joint_names == ["right_joint1", "right_joint2", "right_joint3", "right_joint4"]
    middle = 0.5 * (batch.lower + batch.upper)
    assert np.allclose(values.mean(axis=0), middle, atol=0.02 * (batch.upper - batch.lower).max())


def test_volume_estimate_converges():
    result = monte_carlo(shipped("xiang2019"), ["left_ee"], 640_000, seed=3, voxel=0.1)
    volumes = [volume for _, volume in result.convergence["left_ee"]]  # at 80k, 160k, 320k, 640k samples
    changes = np.diff(volumes) / volumes[-1]
    assert np.all(changes >= 0)  # more samples never empty a voxel
    assert np.all(np.diff(changes) < 0)  # each doubling adds less
    assert changes[-1] < 0.02  # the last doubling changes the estimate by less than 2 %


def test_voxel_volume_of_a_known_box():
    rng = np.random.default_rng(0)
    points = rng.uniform([0, 0, 0], [1.0, 0.5, 0.2], size=(200_000, 3))
    assert voxel_volume(points, 0.05) == pytest.approx(0.1, rel=1e-9)
    assert common_volume(points, points + [0.5, 0, 0], 0.05) == pytest.approx(0.05, rel=1e-9)


def test_cli_workspace_outputs(tmp_path, capsys):
    assert main(["workspace", "xiang2019", "--ee", "left_ee", "--ee", "right_ee", "-n", "5000",
                 "--out", str(tmp_path), "--quiet"]) == 0
    metrics = json.loads((tmp_path / "metrics.json").read_text())
    assert metrics["samples"] == 5000 and set(metrics["volume"]) == {"left_ee", "right_ee", "common"}
    assert metrics["volume"]["common"] < metrics["volume"]["left_ee"] and metrics["samples_per_second"] > 0
    points = np.load(tmp_path / "points.npz")
    assert points["q_left_ee"].shape == (5000, 4) and points["position_right_ee"].shape == (5000, 3)
    assert (tmp_path / "workspace.png").stat().st_size > 20_000
    assert main(["workspace", "xiang2019", "--ee", "nosuch", "-n", "10"]) == 2


@pytest.mark.parametrize("directions", [1, 2, 3, 10, 100, 200])
def test_direction_cells_have_equal_area(directions, rng):
    grid = OrientationGrid(directions, 1)
    assert grid.ring_counts.sum() == directions and grid.count == directions
    assert np.array_equal(grid.direction_cells(grid.centres), np.arange(directions))  # a centre is in its cell
    vectors = rng.normal(size=(200 * directions, 3))  # uniform directions, 200 per cell on average
    counts = np.bincount(grid.direction_cells(vectors), minlength=directions)
    assert np.abs(counts / 200.0 - 1.0).max() < 6 * np.sqrt(1 / 200)  # equal area: Poisson noise only (6 sigma)


def test_orientation_cells_have_equal_volume(rng):
    grid = OrientationGrid()  # 100 directions x 18 roll bins
    counts = np.bincount(grid.cells(uniform_rotations(360_000, rng)), minlength=grid.count)
    assert grid.count == 1800 and counts.min() > 0
    poisson = 1 / np.sqrt(counts.mean())  # relative spread of equal-volume cells
    assert counts.std() / counts.mean() < 1.3 * poisson  # cell volumes equal to within a few per cent


def test_dexterity_of_a_free_rotation_chain_tends_to_one():
    # three revolute joints about z, y, x through one point, ranges [-pi, pi]: every orientation, one position
    wrist = uvms.load(chain_urdf(["0 0 1", "0 1 0", "1 0 0"], [0, 0, 0], base_xyz="0.05 0.05 0.05"))
    result = monte_carlo(wrist, ["ee"], 40_000, seed=1, dexterity=True, progress=False)
    dexterity = result.dexterity["ee"]
    assert len(dexterity.samples) == 1 and dexterity.samples[0] == 40_000
    assert np.allclose(dexterity.centres, [[0.05, 0.05, 0.05]])
    means = [mean for _, mean in result.dexterity_convergence["ee"]]  # 10k, 20k, 40k samples
    assert np.all(np.diff(means) >= 0) and means[0] < 1.0  # a lower bound that grows with the samples
    assert means[-1] >= 0.995 and dexterity.volume(0.99) == pytest.approx(0.1**3)
    directions_only = monte_carlo(wrist, ["ee"], 5000, dexterity=OrientationGrid(200, 1), progress=False)
    assert directions_only.dexterity["ee"].mean == 1.0


@pytest.mark.parametrize("grid", [OrientationGrid(200, 1, "x"), OrientationGrid()], ids=["approach-x", "so3"])
def test_dexterity_of_a_planar_arm_is_the_cells_of_a_great_circle(grid):
    # a planar 3R arm (0.5, 0.5, 0.1 m) reaches only rotations about z: its x axis sweeps the equator
    planar = uvms.load(chain_urdf(["0 0 1"] * 3, [0, 0.5, 0.5], ee_xyz="0.1 0 0", base_xyz="0 0 0.05"))
    circle = np.unique(grid.cells(yaw_rotations(np.linspace(-np.pi, np.pi, 100_001))))
    expected = len(circle) / grid.count  # 26 of 200 direction cells; 18 (one per roll bin) of 1800 cells
    result = monte_carlo(planar, ["ee"], 100_000, seed=2, dexterity=grid, progress=False)
    dexterity = result.dexterity["ee"]
    batch = BatchKinematics(planar, "ee")
    _, axes = batch.positions_and_axes(result.joints["ee"], grid.axes)
    assert np.all(np.isin(grid.cells_from_axes(axes), circle))  # never off the great circle
    assert dexterity.dexterity.max() == pytest.approx(expected)
    radius = np.linalg.norm(dexterity.centres[:, :2], axis=1)
    inner = (radius > 0.2) & (radius < 0.75)  # every yaw is reachable from every point of these voxels
    assert inner.sum() > 100 and np.all(dexterity.dexterity[inner] == pytest.approx(expected))
    assert np.all((dexterity.dexterity >= 0) & (dexterity.dexterity <= 1))


def test_dexterity_of_the_4dof_xiang2019_arm_is_small():
    result = monte_carlo(shipped("xiang2019"), ["left_ee"], 20_000, dexterity=True, progress=False)
    dexterity = result.dexterity["left_ee"]
    assert np.all((dexterity.dexterity > 0) & (dexterity.dexterity <= 1))
    assert dexterity.samples.sum() == 20_000 and dexterity.reached.max() <= dexterity.samples.max()
    # 4 joints reach a 2-D set of orientations (Rz(q1) Rx(-pi/2) Rz(q2 + q3 + q4)): a finding, not a bug
    assert dexterity.mean < 0.01 and dexterity.volume(0.1) == 0.0
    summary = result.metrics()["dexterity"]["frames"]["left_ee"]
    assert summary["mean"] == dexterity.mean and summary["dexterous_volume"] == 0.0


def test_dexterity_map_counts_distinct_cells_per_voxel():
    positions = np.array([[0.01, 0.01, 0.01], [0.02, 0.02, 0.02], [0.03, 0.01, 0.01], [0.15, 0.01, 0.01]])
    dexterity = dexterity_map(positions, np.array([3, 3, 7, 3]), voxel=0.1, total_cells=10)
    assert np.allclose(dexterity.centres, [[0.05, 0.05, 0.05], [0.15, 0.05, 0.05]])
    assert dexterity.reached.tolist() == [2, 1] and dexterity.samples.tolist() == [3, 1]
    assert np.allclose(dexterity.dexterity, [0.2, 0.1]) and dexterity.mean == pytest.approx(0.15)
    assert dexterity.volume(0.15) == pytest.approx(0.001)
    with pytest.raises(WorkspaceInputError, match=r"\[0, 10\)"):
        dexterity_map(positions, np.array([3, 3, 10, 3]), 0.1, 10)


def test_outside_hull_removes_points_inside_the_solids():
    box = HullShape("hull", "box", pin.rpy.rpyToMatrix(0, 0, np.pi / 2), np.array([1.0, 0, 0]),
                    np.array([2.0, 0.6, 0.5]))
    # rotated 90 deg about z: 0.6 m along x, 2 m along y
    points = np.array([[1.0, 0, 0], [1.29, 0.99, 0.24], [1.31, 0, 0], [1.0, 1.01, 0], [1.0, 0, 0.26], [-5, 0, 0]])
    assert outside_hull(points, box).tolist() == [False, False, True, True, True, True]
    cylinder = HullShape("hull", "cylinder", np.eye(3), np.zeros(3), np.array([0.2, 1.0]))
    sphere = HullShape("hull", "sphere", np.eye(3), np.array([0.0, 0, 1]), np.array([0.1]))
    probe = np.array([[0.19, 0, 0.49], [0.21, 0, 0], [0, 0, 0.51], [0, 0.05, 1.05], [0, 0, 0.89]])
    assert outside_hull(probe, [cylinder, sphere]).tolist() == [False, True, True, False, True]
    assert box.volume == pytest.approx(0.6) and cylinder.volume == pytest.approx(np.pi * 0.04)
    with pytest.raises(WorkspaceInputError, match="3 positive"):
        HullShape("hull", "box", np.eye(3), np.zeros(3), np.array([1.0, 1.0]))


def test_hull_is_read_from_the_urdf():
    shapes = hull_shapes(shipped("xiang2019"))  # the visual box of base_link (no collision element)
    assert [(shape.link, shape.kind) for shape in shapes] == [("base_link", "box")]
    assert np.allclose(shapes[0].size, [2.0, 0.6, 0.5]) and np.allclose(shapes[0].centre, 0)
    geometry = ('<collision><origin xyz="0.1 0.2 0.3" rpy="0 0 1.5707963267948966"/>'
                '<geometry><box size="1 2 3"/></geometry></collision>'
                '<visual><geometry><sphere radius="9"/></geometry></visual>')
    robot = uvms.load(chain_urdf(["0 0 1"], [0], base_geometry=geometry))
    (shape,) = hull_shapes(robot)  # collision first
    assert shape.kind == "box" and np.allclose(shape.centre, [0.1, 0.2, 0.3])
    assert np.allclose(np.abs(shape.rotation), [[0, 1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-12)
    assert hull_shapes(robot, element="visual")[0].kind == "sphere"
    with pytest.raises(WorkspaceInputError, match="valid: base_link"):
        hull_shapes(robot, links=["l0"])
    with pytest.raises(WorkspaceInputError, match="no box, cylinder, sphere or mesh"):
        hull_shapes(uvms.load(chain_urdf(["0 0 1"], [0])))


def test_hull_removal_never_increases_the_volume():
    robot = shipped("xiang2019")
    result = monte_carlo(robot, ["left_ee", "right_ee"], 20_000, remove_hull=True, progress=False)
    for frame in result.frames:
        assert result.volume_outside_hull[frame] <= result.volume[frame]
        # the arms hang below the hull (q1 in [-130, 0] deg from a mount 6 cm under it): nothing is removed
        assert result.outside_hull[frame].all() and result.positions[frame][:, 2].max() < -0.25
    assert result.common_volume_outside_hull <= result.common_volume
    tall = uvms.load("xiang2019", args={"hull_height": 1.0})  # the hull now reaches 0.19 m below the shoulders
    result = monte_carlo(tall, ["left_ee", "right_ee"], 20_000, remove_hull=True, progress=False)
    for frame in result.frames:
        inside = ~result.outside_hull[frame]
        assert inside.any() and np.all(result.positions[frame][inside][:, 2] >= -0.5)
        assert result.volume_outside_hull[frame] < result.volume[frame]
        assert len(result.cloud(frame)) == np.count_nonzero(~inside)
    assert result.metrics()["hull"][0]["size"] == [2.0, 0.6, 1.0]


def test_bad_workspace_arguments_raise_workspace_errors():
    robot = shipped("xiang2019")
    for kwargs, words in [({"samples": 0}, "integer >= 1"), ({"samples": -3}, "integer >= 1"),
                          ({"samples": 1.5}, "integer >= 1"), ({"samples": 1e9}, "integer >= 1"),
                          ({"samples": True}, "integer >= 1"), ({"samples": "10"}, "integer >= 1"),
                          ({"keep_points": -1}, "keep_points"), ({"chunk": 0}, "chunk"), ({"voxel": 0.0}, "voxel size"),
                          ({"dexterity_voxel": -1.0}, "dexterity voxel"), ({"frames": []}, "at least one")]:
        arguments = {"robot": robot, "frames": ["left_ee"], "samples": 10, **kwargs}
        with pytest.raises(WorkspaceInputError, match=words):
            monte_carlo(**arguments)
    with pytest.raises(uvms.errors.FrameNotFound):
        monte_carlo(robot, ["left_eee"], 10)
    for kwargs, words in [({"directions": 0}, "directions"), ({"roll_bins": 1.5}, "roll_bins"),
                          ({"approach": "w"}, "x, y, z")]:
        with pytest.raises(WorkspaceInputError, match=words):
            OrientationGrid(**kwargs)
    assert issubclass(WorkspaceInputError, uvms.UVMSError)


def test_cli_workspace_dexterity_hull_and_figures(tmp_path, capsys):
    assert main(["workspace", "xiang2019", "--ee", "left_ee", "-n", "4000", "--figures", "1000,4000",
                 "--dexterity", "--remove-hull", "--approach", "x", "--roll-bins", "1", "--directions", "50",
                 "--out", str(tmp_path), "--quiet"]) == 0
    metrics = json.loads((tmp_path / "metrics.json").read_text())
    assert metrics["volume_outside_hull"]["left_ee"] <= metrics["volume"]["left_ee"]
    dexterity = metrics["dexterity"]
    assert (dexterity["cells"], dexterity["approach"], dexterity["voxel"]) == (50, "x", 0.1)
    summary = dexterity["frames"]["left_ee"]
    assert 0 < summary["mean"] <= summary["max"] <= 1 and [n for n, _ in summary["convergence"]] == [1000, 2000, 4000]
    assert metrics["figures"] == ["workspace_1000.png", "workspace_4000.png", "workspace.png", "dexterity_left_ee.png"]
    for name in metrics["figures"]:
        assert (tmp_path / name).stat().st_size > 20_000
    points = np.load(tmp_path / "points.npz")
    assert points["dexterity_left_ee"].shape == (summary["voxels"],) and points["outside_hull_left_ee"].all()
    assert "dexterity mean" in capsys.readouterr().out
    assert main(["workspace", "xiang2019", "-n", "100", "--figures", "1000", "--out", str(tmp_path)]) == 2
    assert "--figures expects" in capsys.readouterr().err


def streamed_result_arrays(result):
    """Everything a WorkspaceResult holds except the timing, as comparable values."""
    metrics = result.metrics()
    metrics.pop("samples_per_second")
    arrays = {f"{name}_{frame}": getattr(result, name)[frame] for name in ("joints", "positions", "outside_hull")
              for frame in result.frames}
    for frame, map_ in result.dexterity.items():
        arrays.update({f"centres_{frame}": map_.centres, f"samples_{frame}": map_.samples,
                       f"reached_{frame}": map_.reached})
    return metrics, arrays


def test_streamed_results_do_not_depend_on_the_chunk_size(monkeypatch):
    tall = uvms.load("xiang2019", args={"hull_height": 1.0})  # the hull removes some samples
    options = {"seed": 11, "dexterity": True, "remove_hull": True, "progress": False}
    frames = ["left_ee", "right_ee"]
    default = monte_carlo(tall, frames, 30_011, **options)  # one chunk of CHUNK per frame
    monkeypatch.setattr(montecarlo, "CHUNK", 997)  # 31 chunks per frame, cut at the convergence counts
    tiny = monte_carlo(tall, frames, 30_011, **options)
    explicit = monte_carlo(tall, frames, 30_011, chunk=61, keep_points=30_011, **{**options, "dexterity": False})
    (metrics, arrays), (tiny_metrics, tiny_arrays) = streamed_result_arrays(default), streamed_result_arrays(tiny)
    assert metrics == tiny_metrics and 0 < metrics["fraction_inside_hull"]["left_ee"] < 1
    assert arrays.keys() == tiny_arrays.keys()
    for name, array in arrays.items():
        assert array.dtype == tiny_arrays[name].dtype and array.tobytes() == tiny_arrays[name].tobytes(), name
    assert explicit.volume == default.volume
    assert explicit.common_volume_outside_hull == default.common_volume_outside_hull
    # the oracle: all samples at once (one draw from the same generator) through the whole-cloud functions
    rng = np.random.default_rng(11)
    clouds = {}
    for frame in frames:
        batch = BatchKinematics(tall, frame)
        values = batch.sample(30_011, rng)
        assert np.array_equal(values, default.joints[frame])  # chunked draws == one draw
        points, axes = batch.positions_and_axes(values, default.orientation_grid.axes)
        kept = outside_hull(points, default.hull)
        clouds[frame] = points[kept]
        assert default.volume[frame] == voxel_volume(points, 0.05)
        assert default.volume_outside_hull[frame] == voxel_volume(points[kept], 0.05)
        assert default.convergence[frame][0] == (3751, voxel_volume(points[:3751], 0.05))
        reference = dexterity_map(points[kept], default.orientation_grid.cells_from_axes(axes)[kept], 0.1,
                                  default.orientation_grid.count)
        streamed = tiny.dexterity[frame]
        for name in ("centres", "samples", "reached"):
            assert np.array_equal(getattr(streamed, name), getattr(reference, name)), name
    assert default.common_volume_outside_hull == common_volume(clouds["left_ee"], clouds["right_ee"], 0.05)


def test_voxel_occupancy_streams_like_the_whole_cloud(rng):
    points = rng.normal(scale=0.3, size=(50_000, 3))
    other = rng.normal(loc=0.2, scale=0.3, size=(20_000, 3))
    occupancy, second = VoxelOccupancy(0.02), VoxelOccupancy(0.02)
    cuts = np.sort(rng.choice(50_000, 40, replace=False))
    for part in np.split(points, cuts):  # uneven chunks, some tiny
        occupancy.add(part)
    occupancy.add(np.empty((0, 3)))
    second.add(other)
    assert np.array_equal(occupancy.keys, voxel_keys(points, 0.02))
    assert occupancy.volume == voxel_volume(points, 0.02)
    assert occupancy.common_volume(second) == common_volume(points, other, 0.02)


def test_memory_is_bounded_whatever_the_sample_count():
    robot = shipped("xiang2019")
    monte_carlo(robot, ["left_ee"], 100, dexterity=True, remove_hull=True, progress=False)  # imports, caches

    def peak(samples):
        tracemalloc.start()  # numpy reports its array buffers to tracemalloc
        try:
            monte_carlo(robot, ["left_ee"], samples, chunk=10_000, keep_points=1000, dexterity=True,
                        remove_hull=True, progress=False)
            return tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()

    small, large = peak(100_000), peak(1_600_000)  # about 4 MB each
    assert large < 1.25 * small  # does not grow with the samples
    assert large < 1_600_000 * 3 * 8 / 4  # far below one (N, 3) array of positions


def test_points_kept_are_capped_and_metrics_say_so(tmp_path, capsys, monkeypatch):
    arguments = ["workspace", "xiang2019", "--ee", "left_ee", "--ee", "right_ee", "-n", "10_000", "--remove-hull",
                 "--figures", "2000,5000", "--quiet"]
    assert main([*arguments, "--out", str(tmp_path / "all")]) == 0
    monkeypatch.setattr(montecarlo, "POINTS_KEPT", 3000)
    assert main([*arguments, "--out", str(tmp_path / "capped")]) == 0
    assert "keep the first 3000 of the 10000 samples" in capsys.readouterr().out
    metrics = json.loads((tmp_path / "capped" / "metrics.json").read_text())
    assert metrics["points_sampled"] == {"left_ee": 10_000, "right_ee": 10_000}
    assert metrics["points_stored"] == {"left_ee": 3000, "right_ee": 3000}
    assert "first 3000 of the 10000" in metrics["points_note"]
    full = json.loads((tmp_path / "all" / "metrics.json").read_text())
    assert full["points_stored"] == full["points_sampled"] and full["points_note"].startswith("all 10000")
    for key in ("volume", "volume_outside_hull", "volume_convergence", "fraction_inside_hull"):
        assert metrics[key] == full[key]  # every sample counts, whatever is kept
    points, all_points = np.load(tmp_path / "capped" / "points.npz"), np.load(tmp_path / "all" / "points.npz")
    for frame in ("left_ee", "right_ee"):
        assert points[f"q_{frame}"].shape == (3000, 4) and points[f"outside_hull_{frame}"].shape == (3000,)
        assert np.array_equal(points[f"position_{frame}"], all_points[f"position_{frame}"][:3000])  # the first drawn
    assert metrics["figures"] == ["workspace_2000.png", "workspace_5000.png", "workspace.png"]
    result = monte_carlo(shipped("xiang2019"), ["left_ee"], 5000, keep_points=100, progress=False)
    assert result.stored("left_ee") == 100 and len(result.cloud("left_ee")) == 100
    with pytest.raises(WorkspaceInputError, match="only the first 100 of the 5000"):
        result.cloud("left_ee", 101)
    assert monte_carlo(shipped("xiang2019"), ["left_ee"], 50, keep_points=0, progress=False).metrics()[
        "points_stored"] == {"left_ee": 0}


class StopSampling(Exception):
    """Raised by `FirstChunkBar` to end a run after its first chunk."""


class FirstChunkBar:
    """A stand-in for tqdm that records the total and stops the run at the first update."""

    made = []

    def __init__(self, total=None, **kwargs):
        self.total, self.updates = total, []
        FirstChunkBar.made.append(self)

    def set_postfix_str(self, *args, **kwargs):
        pass

    def update(self, count):
        self.updates.append(count)
        raise StopSampling

    def close(self):
        pass


def test_a_billion_samples_start_streaming_without_allocating_them(tmp_path, monkeypatch):
    monkeypatch.setattr(montecarlo, "tqdm", FirstChunkBar)
    monkeypatch.setenv("UVMS_DEBUG", "1")  # let the exception through the CLI
    FirstChunkBar.made.clear()
    tracemalloc.start()
    try:
        with pytest.raises(StopSampling):
            main(["workspace", "xiang2019", "--ee", "left_ee", "--ee", "right_ee", "-n", "1e9", "--dexterity",
                  "--remove-hull", "--figures", "10000,1000000000", "--out", str(tmp_path), "--quiet"])
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    (bar,) = FirstChunkBar.made
    assert bar.total == 2 * 10**9 and bar.updates == [CHUNK]  # the first chunk of the first frame was done
    assert peak < 10**9 * 3 * 8 / 100  # (10^9, 3) positions would be 24 GB
    assert not (tmp_path / "metrics.json").exists()


@pytest.mark.parametrize(("text", "count"), [("1000000000", 10**9), ("1e9", 10**9), ("1_000", 1000), (" 12 ", 12),
                                             ("2.5e3", 2500), (7, 7)])
def test_sample_counts_from_the_command_line(text, count):
    assert parse_sample_count(text) == count


@pytest.mark.parametrize("text", ["0", "-5", "1.5", "abc", "1e400", "nan", "", "1e-3"])
def test_bad_sample_counts_from_the_command_line(text, capsys):
    with pytest.raises(WorkspaceInputError, match="integer >= 1"):
        parse_sample_count(text)
    assert main(["workspace", "xiang2019", "-n", text, "--quiet"]) == 2
    assert "integer >= 1" in capsys.readouterr().err


def test_cli_workspace_replaces_its_folder_whole(tmp_path, capsys):
    out = tmp_path / "ws"
    assert main(["workspace", "xiang2019", "--ee", "left_ee", "-n", "2000", "--figures", "1000",
                 "--out", str(out), "--quiet"]) == 0
    assert (out / "workspace_1000.png").is_file()
    assert main(["workspace", "xiang2019", "--ee", "right_ee", "-n", "3000", "--out", str(out), "--quiet"]) == 0
    assert sorted(p.name for p in out.iterdir()) == [".uvms-run.json", "metrics.json", "points.npz", "workspace.png"]
    assert json.loads((out / "metrics.json").read_text())["samples"] == 3000
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".ws.uvms-tmp")] == []
    user_folder = tmp_path / "documents"
    user_folder.mkdir()
    (user_folder / "thesis.tex").write_text("keep")
    assert main(["workspace", "xiang2019", "--ee", "left_ee", "-n", "10", "--out", str(user_folder), "--quiet"]) == 2
    assert "was not written by uvms" in capsys.readouterr().err
    assert [p.name for p in user_folder.iterdir()] == ["thesis.tex"]


@pytest.mark.parametrize("key_range", [7, 5_000, 10**9])  # dense table, dense tally, np.unique
def test_distinct_keys_equal_numpy_unique_on_every_path(key_range, rng):
    from uvms.workspace.voxels import distinct_keys

    keys = rng.integers(0, key_range, size=3_000)
    weights = rng.integers(1, 9, size=3_000)
    unique, counts = np.unique(keys, return_counts=True)
    assert np.array_equal(distinct_keys(keys, key_range)[0], unique)
    got, got_counts = distinct_keys(keys, key_range, counted=True)
    assert np.array_equal(got, unique) and np.array_equal(got_counts, counts)
    got, got_counts = distinct_keys(keys, key_range, counted=True, counts=weights)
    summed = np.array([weights[keys == key].sum() for key in unique])
    assert np.array_equal(got, unique) and np.array_equal(got_counts, summed) and got_counts.dtype == np.int64
