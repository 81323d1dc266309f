"""A new user's first hour (issue 17, "Scenarios and figures"): scenarios by name, figures that follow the task,
clear weight errors, warnings on the terminal, workspace convergence, run folders that record their model, and
a level vehicle in the initial-configuration optimization."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import uvms
from conftest import shipped
from uvms.cli import main, run_output_folder, scenario_file, view_robot
from uvms.errors import RunRecordError, ScenarioError, SolverInputError
from uvms.scenario import run_scenario, scenario_from_raw
from uvms.scenario.build import build
from uvms.scenario.record import read_run_record
from uvms.scenario.resources import SCENARIOS_DIR, resolve_scenario_path, shipped_scenarios
from uvms.scenario.verdict import LIMIT_SLACK, run_verdict
from uvms.viz.plotting import desired_motion_figure, path_figure
from uvms.workspace import monte_carlo, volume_convergence

FAST = ["outputs.figures=false"]


def one_line_error(capsys) -> str:
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    return err


# ------------------------------------------------------------------ 1. scenarios by name
def test_a_shipped_scenario_runs_by_name_from_any_folder(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)  # no scenarios/ here: the name is looked up in the installed repository
    assert resolve_scenario_path("hoang2011_w1") == SCENARIOS_DIR / "hoang2011_w1.toml"
    assert "santos2006_task_priority" in shipped_scenarios()
    assert main(["run", "santos2006_task_priority", "--out", "tp", "--quiet", "--set", "outputs.figures=false"]) == 0
    out = capsys.readouterr().out
    assert "scenario    santos2006_task_priority  (100 steps" in out
    assert json.loads((tmp_path / "tp" / "metrics.json").read_text())["scenario"] == "santos2006_task_priority"
    # the default folder, and --watch's scenario file, from the name
    options = argparse.Namespace(out=None, scenario="hoang2011_w1", set=None)
    assert run_output_folder(options) == Path("out") / "hoang2011_w1"
    assert scenario_file("hoang2011_w1") == SCENARIOS_DIR / "hoang2011_w1.toml"


def test_a_file_of_ones_own_wins_over_a_shipped_name(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "hoang2011_w1").write_text((SCENARIOS_DIR / "santos2006_task_priority.toml").read_text()
                                           .replace("../models/", f"{SCENARIOS_DIR.parent}/models/"))
    assert resolve_scenario_path("hoang2011_w1") == Path("hoang2011_w1")


def test_an_unknown_scenario_name_lists_the_close_shipped_ones(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["run", "hoang2011_w2"]) == 2
    err = one_line_error(capsys)
    assert "not a shipped scenario name" in err and "close shipped scenarios: hoang2011_w1" in err
    assert main(["run", "nothing_like_it.toml"]) == 2
    assert "shipped scenarios: amundsen2018" in one_line_error(capsys)


def test_sweep_takes_a_scenario_name(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["sweep", "santos2006_task_priority", "--grid", "solver.gain=[1.0, 2.0]", "--out", "sw",
                 "--quiet"]) == 0
    assert "point_*" in capsys.readouterr().out
    rows = (tmp_path / "sw" / "sweep.csv").read_text().splitlines()
    assert len(rows) == 3 and rows[1].endswith(",")  # two points, no error


# ------------------------------------------------------------------ 2. figures follow the task
def yz_circle(tmp_path: Path, axes: list[str]) -> Path:
    """A 5 cm circle in the y-z plane of the world, driven by the bluerov2_alpha5 end effector."""
    path = tmp_path / f"yz_{''.join(axes)}.toml"
    path.write_text(f"""
[model]
path = "bluerov2_alpha5"
[task]
axes = {json.dumps(axes)}
[trajectory]
type = "circle"
center_offset = [0.0, 0.0, 0.05]
normal = [1.0, 0.0, 0.0]
law = "quintic"
duration = 4.0
[initial]
arm = [3.0, 1.5, 1.5, 3.0, 0.005]
[solver]
gain = 5.0
[simulation]
dt = 0.02
""")
    return path


def ylabels(figure) -> list[str]:
    return [axis.get_ylabel() for axis in figure.axes]


def test_a_circle_in_the_y_z_plane_is_drawn_in_3d_when_the_task_is_3d(tmp_path):
    result = run_scenario(yz_circle(tmp_path, ["x", "y", "z"]), out=tmp_path / "yz3", progress=False)
    assert result.metrics["max_position_error"] < 1e-6
    assert np.ptp(result.simulation.desired_position[:, 2]) == pytest.approx(0.1, rel=1e-6)  # it moves in z
    path = path_figure(result.simulation, "yz")
    (axis,) = path.axes
    assert axis.name == "3d"
    assert (axis.get_xlabel(), axis.get_ylabel(), axis.get_zlabel()) == ("x [m]", "y [m]", "z [m]")
    assert "3-D" in axis.get_title()
    desired = desired_motion_figure(result.simulation, result.setup.trajectory, "yz")
    assert ylabels(desired) == ["speed [m/s]", "x_d [m]", "y_d [m]", "z_d [m]"]  # z was missing before
    assert np.ptp(desired.axes[3].lines[0].get_ydata()) == pytest.approx(0.1, rel=1e-6)
    for name in ("path.png", "desired_motion.png"):
        assert (tmp_path / "yz3" / name).stat().st_size > 10_000


def test_a_planar_task_is_drawn_in_its_own_plane(tmp_path):
    result = run_scenario(yz_circle(tmp_path, ["y", "z"]), out=tmp_path / "yz2", progress=False, overrides=FAST)
    (axis,) = path_figure(result.simulation, "yz").axes
    assert axis.name != "3d"
    assert (axis.get_xlabel(), axis.get_ylabel()) == ("y [m]", "z [m]")
    assert "the y-z plane" in axis.get_title()
    desired = desired_motion_figure(result.simulation, result.setup.trajectory, "yz")
    assert ylabels(desired) == ["speed [m/s]", "y_d [m]", "z_d [m]"]
    # a planar vehicle's x, y, yaw task keeps its x-y figure
    hoang = run_scenario("hoang2011_w1_euler", out=tmp_path / "h", progress=False,
                overrides=[*FAST, "simulation.duration=2"])
    (axis,) = path_figure(hoang.simulation, "h").axes
    assert (axis.get_xlabel(), axis.get_ylabel(), axis.get_title()) == ("x [m]", "y [m]", "h: paths in the x-y plane")
    assert ylabels(desired_motion_figure(hoang.simulation, hoang.setup.trajectory)) == [
        "speed [m/s]", "x_d [m]", "y_d [m]", "yaw_d [rad]"]


# ------------------------------------------------------------------ 3. weights of a free-floating run
def test_free_floating_weights_of_size_nv_name_the_key_and_the_arm_joints(tmp_path):
    for name, extra in (("hoang2011_gjm", []), ("hoang2011_w1_euler", ["solver.free_floating=true"])):
        with pytest.raises(ScenarioError) as caught:
            run_scenario(name, out=tmp_path / name, overrides=[*FAST, *extra, "solver.weights=[1, 1, 1, 1, 1, 1]"])
        message = str(caught.value)
        assert "solver.weights has 6 numbers, hoang2011_uvms needs 3" in message
        assert "free-floating (generalized-Jacobian) weights cover the arm joints only" in message
    with pytest.raises(ScenarioError, match=r"needs 6: one per velocity coordinate: the vehicle \(x, y, yaw\)"):
        run_scenario("hoang2011_w1_euler", out=tmp_path / "k", overrides=[*FAST, "solver.weights=[1, 1, 1]"])
    robot = shipped("hoang2011")
    task = uvms.FrameTask(robot, axes=["x", "y"])
    task.set_target(np.zeros(6))
    with pytest.raises(SolverInputError, match=r"W must be \(3,\).*arm joints only"):
        uvms.CLIKSolver(robot, task, weights=np.ones(robot.nv), free_floating=True)


# ------------------------------------------------------------------ 4. limits and tolerance on the terminal
def test_a_run_that_leaves_its_joint_limits_says_so_on_the_terminal(tmp_path, capsys):
    assert main(["run", "hoang2011_w1_euler", "--out", str(tmp_path / "lim"), "--quiet",
                 "--set", "outputs.figures=false", "--set", "model.args.q23_max=0.6",
                 "--set", "model.args.q23_min=-0.6", "--set", "solver.alpha=0",
                 "--set", "simulation.duration=30"]) == 0
    captured = capsys.readouterr()
    assert "verdict     WARNING: joint limits left" in captured.out
    assert captured.err.startswith("uvms: warning: hoang2011_w1_euler: the arm left its joint limits by up to")
    verdict = json.loads((tmp_path / "lim" / "metrics.json").read_text())["verdict"]
    assert verdict["ok"] is False and verdict["within_joint_limits"] is False and verdict["within_tolerance"]


def test_a_task_error_above_the_stated_tolerance_says_so_and_the_default_passes_a_good_run(tmp_path, capsys):
    assert main(["run", "hoang2011_w1_euler", "--out", str(tmp_path / "a"), "--quiet", "--set",
                 "outputs.figures=false", "--set", "simulation.duration=20"]) == 0
    captured = capsys.readouterr()
    assert "verdict     ok: inside the joint limits, errors <= 0.01 m and 0.0175 rad" in captured.out
    assert captured.err == ""
    assert main(["run", "hoang2011_w1_euler", "--out", str(tmp_path / "b"), "--quiet", "--set",
                 "outputs.figures=false", "--set", "simulation.duration=20", "--set",
                 "outputs.position_tolerance=1e-6"]) == 0
    captured = capsys.readouterr()
    assert "task error above the tolerance" in captured.out
    assert "above outputs.position_tolerance = 1e-06 m" in captured.err
    metrics = json.loads((tmp_path / "b" / "metrics.json").read_text())
    assert metrics["verdict"]["within_tolerance"] is False and metrics["verdict"]["position_tolerance"] == 1e-6
    with pytest.raises(ScenarioError, match="outputs.position_tolerance = 0 is out of range"):
        run_scenario("hoang2011_w1_euler", out=tmp_path / "c", overrides=["outputs.position_tolerance=0"])


def test_rounding_at_a_limit_is_not_a_violation():
    base = {"max_position_error": 0.0, "max_orientation_error": 0.0}
    tolerances = {"position_tolerance": 0.01, "orientation_tolerance": 0.0175}
    assert run_verdict({**base, "max_joint_limit_violation": 3.4e-11}, tolerances)["ok"]  # xiang2019_grip's
    assert not run_verdict({**base, "max_joint_limit_violation": 10 * LIMIT_SLACK}, tolerances)["ok"]
    assert not run_verdict({**base, "max_joint_limit_violation": 0.0, "max_orientation_error": 0.02},
                           tolerances)["within_tolerance"]


# ------------------------------------------------------------------ 5. workspace convergence
def test_volume_convergence_from_the_last_doubling():
    converged = volume_convergence([(250, 0.5), (500, 0.9), (1000, 0.995), (2000, 1.0)], tolerance=0.01)
    assert converged.converged and converged.change == pytest.approx(0.005)
    short = volume_convergence([(250, 0.2), (500, 0.4), (1000, 0.6), (2000, 0.8)], tolerance=0.01)
    assert not short.converged and short.change == pytest.approx(0.25)
    # growth per doubling 0.333 -> 0.25 (ratio 0.75): 0.25 * 0.75^k <= 0.01 after k = 12 doublings: beyond 10
    assert short.suggested_samples is None and "more than -n 2048000" in short.warning("ee")
    halving = volume_convergence([(1000, 0.6), (2000, 0.8), (4000, 0.9)], tolerance=0.01)
    # changes 0.25 then 0.111 (ratio 0.444): 0.111 * 0.444^k <= 0.01 after k = 3 doublings
    assert halving.suggested_samples == 4000 * 2**3
    assert np.isnan(volume_convergence([(10, 0.0)]).change)


def test_workspace_prints_whether_the_volume_has_converged(tmp_path, capsys):
    assert main(["workspace", "hoang2011", "-n", "20000", "--out", str(tmp_path / "few"), "--quiet"]) == 0
    captured = capsys.readouterr()
    assert "ee           volume NOT converged: +6.17 % over the last doubling (10000 -> 20000 samples; " \
           "tolerance 1 %)" in captured.out
    assert captured.err.startswith("uvms: warning: the ee volume has not converged") and "-n 160000" in captured.err
    metrics = json.loads((tmp_path / "few" / "metrics.json").read_text())
    assert metrics["volume_converged"]["ee"]["converged"] is False
    assert main(["workspace", "hoang2011", "-n", "200000", "--out", str(tmp_path / "many"), "--quiet"]) == 0
    captured = capsys.readouterr()
    assert "ee           volume converged: +0.65 %" in captured.out and captured.err == ""
    result = monte_carlo(shipped("hoang2011"), ["ee"], 200_000, progress=False)
    assert result.volume_converged(0.001)["ee"].converged is False  # a tighter tolerance: not yet
    assert main(["workspace", "hoang2011", "--convergence-tolerance", "0", "--out", str(tmp_path / "x")]) == 2
    assert "--convergence-tolerance must be in (0, 1)" in one_line_error(capsys)


# ------------------------------------------------------------------ 6. a run folder records its model
def view_options(result: Path, model: str | None = None, args: list[str] | None = None) -> argparse.Namespace:
    return argparse.Namespace(model=model, result=str(result), arg=args, base=None)


@pytest.fixture(scope="module")
def long_arm_run(tmp_path_factory) -> Path:
    """hoang2011 with l1 = 0.7 m (default 0.4 m), two seconds."""
    folder = tmp_path_factory.mktemp("runs") / "long_arm"
    run_scenario("hoang2011_w1_euler", out=folder, progress=False,
        overrides=[*FAST, "model.args.l1=0.7", "simulation.duration=2"])
    return folder


def test_a_run_folder_records_its_model_and_view_replays_it_on_the_long_arm(long_arm_run):
    record = json.loads((long_arm_run / "metrics.json").read_text())["model"]
    assert record["source"] == str((SCENARIOS_DIR.parent / "models/hoang2011/uvms.urdf.xacro").resolve())
    assert record["args"] == {"l1": 0.7} and record["base"] == "planar" and record["ee"] == ["ee"]
    assert record["scenario"] == "hoang2011_w1_euler" and (record["nq"], record["nv"]) == (7, 6)
    robot, note = view_robot(view_options(long_arm_run))  # `uvms view --result DIR`: nothing else given
    assert note is None
    arrays = np.load(long_arm_run / "trajectory.npz")
    q, ee = arrays["q"][-1], arrays["ee_position"][-1]
    np.testing.assert_allclose(robot.fk(q).translation, ee, atol=1e-12)  # the run's geometry
    default = shipped("hoang2011")
    assert np.linalg.norm(default.fk(q).translation - ee) > 0.1  # not the default arm's


def test_view_refuses_a_model_that_contradicts_the_record(long_arm_run, tmp_path, capsys):
    png = str(tmp_path / "a.png")
    assert main(["view", "--result", str(long_arm_run), "--headless", png]) == 0
    assert main(["view", "hoang2011", "--arg", "l1=0.7", "--result", str(long_arm_run), "--headless", png]) == 0
    capsys.readouterr()
    for argv in (["view", "hoang2011"], ["view", str(SCENARIOS_DIR / "hoang2011_w1_euler.toml")], ["view", "--arg", "l1=0.5"]):
        assert main([*argv, "--result", str(long_arm_run), "--headless", png]) == 2
        err = one_line_error(capsys)
        assert "contradicts the model" in err and "joint q2 placed differently" in err
        assert "args l1=0.7, base planar" in err and "drop the model argument" in err


def test_an_older_run_without_a_record_keeps_working_with_a_note(long_arm_run, tmp_path, capsys):
    folder = tmp_path / "old"
    folder.mkdir()
    (folder / "trajectory.npz").write_bytes((long_arm_run / "trajectory.npz").read_bytes())
    metrics = json.loads((long_arm_run / "metrics.json").read_text())
    del metrics["model"]
    (folder / "metrics.json").write_text(json.dumps(metrics))
    assert main(["view", "hoang2011", "--arg", "l1=0.7", "--result", str(folder), "--headless",
                 str(tmp_path / "b.png")]) == 0
    out = capsys.readouterr().out
    assert "does not record its model (a run of an older uvms)" in out and out.count("note") == 1
    assert main(["view", "--result", str(folder), "--headless", str(tmp_path / "c.png")]) == 2
    assert "uvms view needs the model" in one_line_error(capsys)
    metrics["model"] = {"source": "hoang2011", "args": {"l1": [1]}, "base": "planar"}
    (folder / "metrics.json").write_text(json.dumps(metrics))
    with pytest.raises(RunRecordError, match="args must map names to numbers"):
        read_run_record(folder)


# ------------------------------------------------------------------ 7. a level vehicle in the q0 optimization
def level_vehicle_scenario(fixed: list[str]) -> dict:
    """bluerov2_alpha5: q0 optimized to put the end effector on a pose reached with roll 0.05, pitch -0.03."""
    robot = shipped("bluerov2_alpha5")
    target = robot.fk(robot.configuration(base=np.array([0.2, 0.1, -0.1, 0.05, -0.03, 0.4]),
                                          arm=np.array([2.0, 1.2, 1.0, 2.5, 0.005])))
    raw = {"model": {"path": "bluerov2_alpha5"},
           "trajectory": {"type": "line", "start": target.translation.tolist(),
                          "orientation": pin.rpy.matrixToRpy(target.rotation).tolist(),
                          "end_offset": [0.0, 0.0, 0.05], "duration": 1.0},
           "initial": {"method": "optimize", "base": [0.0, 0.0, 0.0, 0.05, -0.03, 0.0], "fixed_base": fixed},
           "simulation": {"dt": 0.05}}
    return scenario_from_raw(raw, "level.toml")


def test_initial_fixed_base_keeps_roll_and_pitch_and_still_reaches_the_target():
    robot = shipped("bluerov2_alpha5")
    free = build(level_vehicle_scenario([]))
    assert np.max(np.abs(robot.base_values(free.q0)[3:5] - [0.05, -0.03])) > 0.05  # it tilts when free to
    level = build(level_vehicle_scenario(["roll", "pitch"]))
    np.testing.assert_allclose(robot.base_values(level.q0)[3:5], [0.05, -0.03], atol=1e-9)
    assert level.initial_residual <= 1e-10
    target = level.task.target  # the start pose of the trajectory
    pose = robot.fk(level.q0, level.task.frame)
    np.testing.assert_allclose(pose.translation, target.translation, atol=1e-9)
    np.testing.assert_allclose(pose.rotation, target.rotation, atol=1e-9)


def test_initial_fixed_base_names_are_checked():
    with pytest.raises(ScenarioError, match="unknown vehicle coordinate 'rol'; close names: roll"):
        build(level_vehicle_scenario(["rol"]))
    scenario = level_vehicle_scenario(["roll"])
    scenario["initial"]["method"] = "given"
    with pytest.raises(ScenarioError, match="initial.fixed_base .* needs initial.method = 'optimize'"):
        build(scenario)
