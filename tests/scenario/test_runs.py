"""Running scenarios (uvms.scenario.runs) and `uvms run`: the hoang2011 and santos2006 reproductions, outputs,
overrides and bad input."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import uvms
from uvms.scenario import ScenarioError, read_scenario, run_scenario

from conftest import SCENARIOS

HOANG = ("w1", "w100", "w500", "wpsi500")


@pytest.fixture(scope="module")
def hoang_runs(tmp_path_factory):
    """The four hoang2011 runs (figures only for W = I, to keep the suite short)."""
    out = tmp_path_factory.mktemp("hoang")
    runs = {}
    for name in HOANG:
        overrides = [] if name == "w1" else ["outputs.figures=false"]
        runs[name] = run_scenario(SCENARIOS / f"hoang2011_{name}.toml", out=out / name, overrides=overrides,
                                  progress=False)
    return runs


@pytest.mark.parametrize("name", HOANG)
def test_hoang2011_tracks_to_1e8_inside_the_limits(hoang_runs, name):
    metrics = hoang_runs[name].metrics
    assert metrics["max_position_error"] <= 1e-8  # paper: about 1e-6
    assert metrics["max_orientation_error"] <= 1e-12
    assert metrics["max_joint_limit_violation"] == 0.0
    assert metrics["initial_residual"] <= 1e-10
    assert metrics["steps"] == 9500


def test_hoang2011_weights_shape_the_motion_as_in_the_paper(hoang_runs):
    m = {name: run_.metrics for name, run_ in hoang_runs.items()}
    # Figs. 5-7: the arm moves less as its weights grow; Fig. 7: the arm almost at rest relative to the vehicle
    assert m["w1"]["arm_travel"] > m["w100"]["arm_travel"] > m["w500"]["arm_travel"]
    assert m["w500"]["arm_travel"] < 0.01 * m["w1"]["arm_travel"]
    # Fig. 8: the vehicle orientation nearly constant with the yaw weight 500 (here 1.5 degrees over 190 s)
    assert m["wpsi500"]["vehicle_yaw_range"] < 0.03
    assert m["wpsi500"]["vehicle_yaw_range"] < m["w100"]["vehicle_yaw_range"] / 4 < m["w1"]["vehicle_yaw_range"]
    # and it lets the arm move: a frozen vehicle heading is paid for by the arm
    assert m["wpsi500"]["arm_travel"] > 100 * m["w500"]["arm_travel"]


def test_hoang2011_outputs(hoang_runs):
    result = hoang_runs["w1"]
    folder = result.files[0].parent
    metrics = json.loads((folder / "metrics.json").read_text())
    for key in ("max_position_error", "max_orientation_error", "max_joint_limit_violation", "vehicle_travel",
                "vehicle_yaw_range", "arm_travel", "steps", "wall_time"):
        assert key in metrics
    with open(folder / "trajectory.csv") as handle:
        rows = list(csv.reader(handle))
    assert rows[0][:4] == ["t", "base_x", "base_y", "base_yaw"] and len(rows) == 9502
    assert float(rows[-1][0]) == pytest.approx(190.0)
    arrays = np.load(folder / "trajectory.npz")
    assert arrays["q"].shape == (9501, 7)
    assert np.allclose(arrays["position_error"], [float(r[rows[0].index("position_error")]) for r in rows[1:]])
    for figure in ("desired_motion", "vehicle", "joints", "errors", "path", "vehicle_velocity"):
        assert (folder / f"{figure}.png").stat().st_size > 10_000


def test_santos2006_kinematic_constraint_keeps_the_vehicle_still_and_task_priority_does_not(tmp_path):
    constraint = run_scenario(SCENARIOS / "santos2006_kinematic_constraint.toml", out=tmp_path / "kc",
                              progress=False).metrics
    priority = run_scenario(SCENARIOS / "santos2006_task_priority.toml", out=tmp_path / "tp", progress=False).metrics
    assert constraint["vehicle_travel"] <= 1e-12
    assert priority["vehicle_travel"] > 0.1
    assert constraint["steps"] == priority["steps"] == 100
    for metrics in (constraint, priority):
        assert metrics["max_joint_limit_violation"] == 0.0
        assert metrics["max_position_error"] < 0.1  # Euler steps of 0.1 s on a 0.63 m/s circle
    # the vehicle turns toward the current (0.78 rad) at K = 1 1/s: 1 - exp(-10) of the way
    series = np.load(tmp_path / "kc" / "trajectory.npz")
    yaw = np.arctan2(series["q"][:, 3], series["q"][:, 2])
    assert yaw[-1] == pytest.approx(0.78 * (1 - 0.9**100), abs=1e-9)  # explicit Euler of psi' = 0.78 - psi


def test_set_overrides_change_the_run(tmp_path):
    base = run_scenario(SCENARIOS / "santos2006_kinematic_constraint.toml", out=tmp_path / "a", progress=False,
               overrides=["outputs.figures=false"])
    longer = run_scenario(SCENARIOS / "santos2006_kinematic_constraint.toml", out=tmp_path / "b", progress=False,
                 overrides=["outputs.figures=false", "model.args.l1=2.5", "vehicle.heading=0.5"])
    assert (longer.setup.robot.fk(longer.setup.q0).translation[1]
            > base.setup.robot.fk(base.setup.q0).translation[1] + 0.4)
    assert longer.metrics["arm_travel"] != base.metrics["arm_travel"]
    assert np.arctan2(longer.simulation.q[-1, 3], longer.simulation.q[-1, 2]) == pytest.approx(0.5 * (1 - 0.9**100))


def test_rk4_on_the_manifold_is_fourth_order(tmp_path):
    """Open loop (K = 0, no null space): the tracking error is the integration error alone."""
    errors = []
    for dt in (0.2, 0.1):
        result = run_scenario(SCENARIOS / "hoang2011_w1.toml", out=tmp_path / str(dt), progress=False, overrides=[
            "outputs.figures=false", "solver.gain=0.0", "solver.alpha=0.0", f"simulation.dt={dt}",
            "trajectory.duration=20.0"])
        errors.append(result.metrics["max_position_error"])
    assert errors[0] / errors[1] > 12  # 2^4 = 16 for a fourth-order method


@pytest.mark.parametrize(
    ("overrides", "words"),
    [
        (["solver.gian=2"], "unknown key.*solver.gian.*valid in \\[solver\\]: method, gain"),
        (["solvers.gain=2"], "unknown section.*solvers"),
        (["solver.alpha=fast"], "solver.alpha must be a number"),
        (["solver.method=newton"], "not valid; valid: 'clik', 'task_priority', 'kinematic_constraint'"),
        (["trajectory.center=[1, 2]"], "trajectory.center must have 3 numbers"),
        (["initial.arm=[1.0, 2.0]"], "initial.base/initial.arm"),
        (["model.args.nosuch=1"], "unknown xacro arg"),
        (["solver"], "SECTION.KEY=VALUE"),
    ],
)
def test_bad_scenarios_are_rejected_with_the_valid_choices(tmp_path, overrides, words):
    with pytest.raises(uvms.UVMSError, match=words):
        run_scenario(SCENARIOS / "santos2006_task_priority.toml", out=tmp_path, overrides=overrides, progress=False)


def test_missing_required_key(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text('[model]\npath = "hoang2011"\n[trajectory]\ntype = "circle"\n[simulation]\ndt = 0.1\n')
    with pytest.raises(ScenarioError, match="trajectory.duration is required"):
        read_scenario(path)
    path.write_text("[model\n")
    with pytest.raises(ScenarioError, match="invalid TOML"):
        read_scenario(path)


def test_cli_run_and_its_errors(tmp_path):
    command = [sys.executable, "-m", "uvms.cli", "run", str(SCENARIOS / "santos2006_task_priority.toml"),
               "--out", str(tmp_path / "cli"), "--set", "outputs.figures=false"]
    result = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    assert "vehicle_travel" in result.stdout and (tmp_path / "cli" / "metrics.json").exists()
    bad = subprocess.run(command + ["--set", "solver.gain=[1, 2, 3, 4]"], capture_output=True, text=True, timeout=300)
    assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1 and "Traceback" not in bad.stderr
    unwritable = subprocess.run(command[:5] + ["--out", "/proc/uvms-cannot-write"], capture_output=True, text=True,
                                timeout=300)
    assert unwritable.returncode == 2 and "cannot write" in unwritable.stderr


# ------------------------------------------------------------------ names, step counts, numbers out of range
GRIP = SCENARIOS / "xiang2019_grip.toml"


def files_below(folder: Path) -> list[Path]:
    return [path for path in folder.rglob("*") if not path.is_dir()]


@pytest.mark.parametrize(
    ("scenario", "key", "value"),
    [
        ("santos2006_task_priority", "scenario.name", "{tmp}/absolute"),
        ("santos2006_task_priority", "scenario.name", "../x"),
        ("santos2006_task_priority", "scenario.name", "a/b"),
        ("santos2006_task_priority", "scenario.name", ".."),
        ("santos2006_task_priority", "scenario.name", ".hidden"),
        ("santos2006_task_priority", "scenario.name", "x" * 129),
        ("xiang2019_grip", "outputs.animation", "../../x.gif"),
        ("xiang2019_grip", "outputs.animation", "{tmp}/x.gif"),
        ("xiang2019_grip", "outputs.animation", "sub/x.gif"),
        ("xiang2019_grip", "outputs.animation", "grip.txt"),
    ],
)
def test_names_from_a_scenario_never_become_paths(tmp_path, monkeypatch, scenario, key, value):
    work = tmp_path / "one" / "two"
    work.mkdir(parents=True)
    monkeypatch.chdir(work)  # the default --out is out/<scenario name>, relative to here
    override = f"{key}={json.dumps(value.format(tmp=tmp_path))}"
    with pytest.raises(ScenarioError, match=f"{key} = .* is not valid: .*plain name: letters, digits"):
        run_scenario(SCENARIOS / f"{scenario}.toml", overrides=[override, "outputs.figures=false"], progress=False)
    assert not files_below(tmp_path) and not (tmp_path / "absolute").exists()


def test_plain_names_are_accepted(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    result = run_scenario(SCENARIOS / "santos2006_task_priority.toml", progress=False,
                 overrides=['scenario.name="my-run_2.v1"', "outputs.figures=false"])
    assert result.files[0].parent == Path("out") / "my-run_2.v1" and result.metrics["scenario"] == "my-run_2.v1"
    assert read_scenario(GRIP, ['outputs.animation="Grip.MP4"']).outputs.animation == "Grip.MP4"
    from uvms.io.names import plain_file_name

    assert plain_file_name("hoang2011_w1", "scenario") == "hoang2011_w1"  # the shipped scenarios keep their names
    assert plain_file_name("my run (2)", "scenario") == "my_run_2_" and plain_file_name("..", "scenario") == "scenario"
    assert plain_file_name("rexrov/end_effector", "frame") == "rexrov_end_effector"  # a frame name: no subfolder


def test_cli_refuses_a_path_as_scenario_name_in_one_line(tmp_path):
    bad = subprocess.run([sys.executable, "-m", "uvms.cli", "run", str(SCENARIOS / "santos2006_task_priority.toml"),
                          "--set", 'scenario.name="../../escaped"'], capture_output=True, text=True, timeout=300,
                         cwd=tmp_path)
    assert bad.returncode == 2 and len(bad.stderr.splitlines()) == 1 and "scenario.name" in bad.stderr
    assert not list(tmp_path.iterdir()) and not (tmp_path.parent / "escaped").exists()


def test_step_count_is_bounded_before_anything_runs(tmp_path, monkeypatch):
    from uvms.errors import StepCountError
    from uvms.numerics import integrate

    def never(*args, **kwargs):
        raise AssertionError("the simulation must not start")

    monkeypatch.setattr("uvms.scenario.runs.simulate", never)
    started = time.perf_counter()
    with pytest.raises(StepCountError, match=r"simulation.dt = 1e-07 s over 190 s gives 1.9e\+09 steps; at most "
                                             r"200,000 are allowed .*raise simulation.dt or shorten"):
        run_scenario(SCENARIOS / "hoang2011_w1.toml", out=tmp_path / "run", overrides=["simulation.dt=1e-7"],
                     progress=False)
    assert time.perf_counter() - started < 30 and not (tmp_path / "run").exists()
    with pytest.raises(StepCountError, match="longer than trajectory.duration = 10 s: the run would have no step"):
        run_scenario(SCENARIOS / "santos2006_task_priority.toml", out=tmp_path / "run", overrides=["simulation.dt=100"])
    with pytest.raises(StepCountError, match="simulation.dt = 1 s is longer than simulation.duration = 0.5 s"):
        run_scenario(SCENARIOS / "santos2006_task_priority.toml", out=tmp_path / "run",
            overrides=["simulation.dt=1.0", "simulation.duration=0.5"])
    for dt in ("0", "-0.1"):
        with pytest.raises(ScenarioError, match=r"simulation.dt = .* is out of range: it is the integration step"):
            run_scenario(SCENARIOS / "santos2006_task_priority.toml", out=tmp_path / "run",
                         overrides=[f"simulation.dt={dt}"])
    amundsen = SCENARIOS / "amundsen2018_rigid_open_loop.toml"  # the dynamic plant: the same check
    monkeypatch.setattr("uvms.scenario.runs.simulate", never)
    with pytest.raises(StepCountError, match="at most 200,000"):
        run_scenario(amundsen, out=tmp_path / "run", overrides=["simulation.dt=1e-6"], progress=False)
    assert not (tmp_path / "run").exists()
    assert integrate.step_count(190.0, 0.02) == 9500 and integrate.step_count(1.0, 1.0) == 1
    assert integrate.step_count(1.0, 1.0 / integrate.MAX_STEPS) == integrate.MAX_STEPS


def test_library_simulations_share_the_step_bound():
    from uvms.dynamics.plant.plant import Plant
    from uvms.errors import StepCountError
    from uvms.sim import simulate

    robot = uvms.load("hoang2011")
    task = uvms.FrameTask(robot, axes=("x", "y", "yaw"))

    def never(*args):
        raise AssertionError("nothing may run")

    for dt, duration, words in ((1e-7, 190.0, "gives 1.9e\\+09 steps"), (2.0, 1.0, "no step"),
                                (0.0, 1.0, "finite and > 0"), (0.1, float("nan"), "finite and > 0")):
        with pytest.raises(StepCountError, match=words):
            simulate(robot, never, robot.neutral(), duration, dt, task=task, desired=never)
        with pytest.raises(StepCountError, match=words):
            simulate(Plant(robot, added_mass=False, damping=False), never, robot.neutral(), duration, dt)


@pytest.mark.parametrize(
    "override",
    ["solver.damping=1e300", "solver.gain=1e300", "solver.gain=[1e300, 1, 1]", "solver.alpha=-1e7",
     "solver.weights=[1, 1, 1, 1e300, 1, 1]", "trajectory.speed=1e9", "trajectory.duration=1e300",
     "solver.gain=100000000000000000000000000000000000000000", "vehicle.gain=1e12", "simulation.duration=1e7",
     "initial.arm=[1e300, 0, 0]"],
)
def test_numbers_out_of_range_are_one_scenario_error(tmp_path, override):
    with pytest.raises(ScenarioError, match=r"is out of range: scenario numbers are SI values with \|x\| <= 1e\+06"):
        run_scenario(SCENARIOS / "hoang2011_w1.toml", out=tmp_path / "run", overrides=[override], progress=False)
    assert not (tmp_path / "run").exists()


def test_signs_and_element_types_are_checked(tmp_path):
    for override, words in (("solver.damping=-0.1", "solver.damping = -0.1 is out of range: it is the DLS damping"),
                            ("solver.gain=['a']", "solver.gain must be a number or a list of numbers"),
                            ("vehicle.velocities.surge=1e9", "vehicle.velocities.surge = 1e\\+09 is out of range")):
        with pytest.raises(ScenarioError, match=words):
            read_scenario(SCENARIOS / "santos2006_task_priority.toml", [override])
    from uvms.scenario import read_toml, scenario_from_raw

    raw = read_toml(GRIP)  # phases are tables of an array: not reachable by --set
    raw["phases"][1]["offsets"] = {"left_ee": [0.0, 0.0, -1e7]}
    with pytest.raises(ScenarioError, match="phases\\[1\\].offsets.left_ee = -1e\\+07 is out of range"):
        scenario_from_raw(raw, GRIP)


def test_cli_damping_1e300_is_one_line(tmp_path):
    command = [sys.executable, "-m", "uvms.cli", "run", str(SCENARIOS / "hoang2011_w1.toml"), "--out",
               str(tmp_path / "run"), "--set", "solver.damping=1e300"]
    bad = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert bad.returncode == 2 and bad.stderr.startswith("uvms: error: ") and len(bad.stderr.splitlines()) == 1
    assert "solver.damping = 1e+300 is out of range" in bad.stderr and "Traceback" not in bad.stderr


@pytest.mark.parametrize("error", [OverflowError("(34, 'Numerical result out of range')"),
                                   FloatingPointError("overflow encountered in multiply"),
                                   np.linalg.LinAlgError("Singular matrix"), ZeroDivisionError("float division")])
def test_numerical_failures_become_one_uvms_error_naming_the_scenario(tmp_path, monkeypatch, capsys, error):
    from uvms.cli import main
    from uvms.errors import NumericalError

    def overflowing(*args, **kwargs):
        raise error

    monkeypatch.setattr("uvms.scenario.runs.simulate", overflowing)  # the safety net behind the schema's bounds
    folder = tmp_path / "run"
    with pytest.raises(NumericalError, match=f"scenario 'santos2006_task_priority': the numerics failed "
                                             f"\\({type(error).__name__}: "):
        run_scenario(SCENARIOS / "santos2006_task_priority.toml", out=folder, progress=False)
    assert sorted(path.name for path in tmp_path.iterdir()) == [".run.uvms-lock"]  # no run folder, no temporary
    assert main(["run", str(SCENARIOS / "santos2006_task_priority.toml"), "--out", str(folder), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("uvms: error: scenario 'santos2006_task_priority': the numerics failed")
    assert len(err.splitlines()) == 1


def armless_vehicle(folder: Path) -> Path:
    """The RexROV-sized fixture without its arm (a vehicle alone, its thrusters and hydrodynamics) holding station
    in a 0.3 m/s current for 2 s, written into ``folder``; returns the scenario."""
    import shutil
    import xml.etree.ElementTree as ET

    fixture = Path(__file__).parents[1] / "fixtures" / "rexrov_like"
    for name in ("thrusters.yaml", "hydrodynamics.yaml"):
        shutil.copy(fixture / name, folder)
    tree = ET.parse(fixture / "rexrov_like.urdf")
    for element in list(tree.getroot()):
        if element.get("name") not in ("world", "base_link", "base_joint"):
            tree.getroot().remove(element)
    tree.write(folder / "vehicle.urdf")
    text = (fixture / "station_current.toml").read_text()
    for old, new in (('path = "rexrov_like.urdf"\nee = "tool"', 'path = "vehicle.urdf"'),
                     ('axes = ["x", "y", "z"]', 'frame = "base_link"\naxes = ["x", "y", "z"]'),
                     ("duration = 6.0", "duration = 2.0")):
        assert old in text
        text = text.replace(old, new)
    text = "\n".join(line for line in text.splitlines() if not line.startswith("arm = "))
    (folder / "station.toml").write_text(text)
    return folder / "station.toml"


def test_a_vehicle_without_an_arm_runs_with_its_figures(tmp_path):
    """No arm joints: no joints.png (nothing to draw), every other figure, and the station held in the current."""
    run = run_scenario(armless_vehicle(tmp_path), out=tmp_path / "out", progress=False)
    assert run.setup.robot.n_arm == 0
    names = {path.name for path in run.files}
    assert {"vehicle.png", "errors.png", "path.png", "thrusters.png", "station.png", "metrics.json"} <= names
    assert "joints.png" not in names and all(path.exists() for path in run.files)
    assert run.metrics["verdict"]["ok"] and 1e-4 < run.metrics["vehicle_position_error"] < 0.05
    assert run.metrics["arm_travel"] == 0.0 and "outputs_failed" not in run.metrics


def test_a_figure_that_fails_does_not_lose_the_run(tmp_path, monkeypatch):
    """A defect in drawing (here a figure raising ValueError) leaves the run's data, its metrics and a warning that
    names the failure; a previous run in the folder is replaced by the new, complete data."""
    import uvms.viz.plotting

    def broken(*args, **kwargs):
        raise ValueError("Number of rows must be a positive integer, not 0")

    scenario = SCENARIOS / "hoang2011_w1.toml"
    overrides = ["simulation.duration=1.0"]
    run_scenario(scenario, out=tmp_path / "run", overrides=[*overrides, "outputs.figures=false"], progress=False)
    monkeypatch.setattr(uvms.viz.plotting, "scenario_figures", broken)
    with pytest.warns(uvms.errors.OutputFailedWarning,
                      match="figures could not be written .ValueError: Number of rows"):
        run = run_scenario(scenario, out=tmp_path / "run", overrides=overrides, progress=False)
    metrics = json.loads((tmp_path / "run" / "metrics.json").read_text())
    assert metrics["outputs_failed"] == {"figures": "ValueError: Number of rows must be a positive integer, not 0"}
    assert metrics["steps"] == 50 and np.load(tmp_path / "run" / "trajectory.npz")["q"].shape[0] == 51
    assert {path.name for path in run.files} == {"trajectory.csv", "trajectory.npz", "metrics.json"}
    assert not list((tmp_path / "run").glob("*.png"))


def test_a_near_singular_thruster_layout_holds_station_without_a_pair_fighting_at_its_limits(tmp_path):
    """The Smilodon-sized fixture (no arm, six thrusters, the lateral pair's heights 4e-8 m apart: cond(B) ~ 1e8)
    in a 0.3 m/s cross current. With the rank judged at rounding level (numpy's) the pair pushed against each other
    at +-2000 N 99.8 % of the time (thruster energy 47.8 J in 6 s) for a roll moment of micro-newton-metres; judged
    at RANK_TOLERANCE, roll is left to buoyancy: no saturation, 3 % of the thrust, the same 1.3 cm hold."""
    from uvms.errors import ThrusterLayoutWarning

    scenario = Path(__file__).parents[1] / "fixtures" / "smilodon_like" / "station_current.toml"
    with pytest.warns(ThrusterLayoutWarning, match="missing: a roll moment .only through lateral_fore, lateral_aft"):
        run = run_scenario(scenario, out=tmp_path / "out", progress=False)
    metrics = run.metrics
    assert metrics["saturated_time_fraction"] <= 0.05 and metrics["max_thrust_ratio"] < 0.1
    assert metrics["thruster_energy"] < 5.0 and metrics["vehicle_position_error"] < 0.02
    assert metrics["verdict"]["ok"] and 0.005 < metrics["max_vehicle_tilt"] < 0.03  # rolled by the sway force, righted
