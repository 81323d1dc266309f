"""Set-based task priority and the QP hierarchy in scenarios (uvms.scenario.inequalities): [[inequalities]],
solver.method, metrics.

The shipped scenarios: bluerov2_alpha5_panel (a point on a panel near the seabed, level, inside the limits),
bluerov2_alpha5_free_floating_limit (non-redundant, the limit wins over the task) and hoang2011_w1_set_based
(the circle with set-based joint limits instead of the potential).
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from uvms.cli import main
from uvms.errors import ScenarioError
from uvms.scenario import read_scenario, run_scenario
from uvms.tasks.objectives import INEQUALITY_TYPES

from conftest import NO_FIGURES, SCENARIOS

PANEL = SCENARIOS / "bluerov2_alpha5_panel.toml"
FREE_FLOATING = SCENARIOS / "bluerov2_alpha5_free_floating_limit.toml"
MAX_TILT = 0.0873  # [rad] the panel scenario's vehicle_attitude


@pytest.fixture(scope="module")
def panel_runs(tmp_path_factory) -> dict:
    """The panel scenario under the three methods (clik: the inequalities monitored only)."""
    root = tmp_path_factory.mktemp("panel")
    return {method: run_scenario(PANEL, root / method, [*NO_FIGURES, f"solver.method={method}"], progress=False)
            for method in ("set_based", "hqp", "clik")}


@pytest.mark.parametrize("method", ["set_based", "hqp"])
def test_panel_reached_level_inside_every_limit(panel_runs, method):
    metrics = panel_runs[method].metrics
    assert metrics["inequalities_enforced"] is True
    assert metrics["final_position_error"] <= 1e-8  # measured 7e-10: the task is feasible with the inequalities
    assert metrics["max_joint_limit_violation"] == 0.0
    assert metrics["max_vehicle_tilt"] <= MAX_TILT  # measured 0.0767 (set_based), 0.0872 (hqp) rad
    assert metrics["inequalities"]["seabed_clearance"]["value_range"][0] >= 0.5  # measured 0.526, 0.504 m
    assert metrics["inequalities"]["panel_clearance"]["value_range"][0] >= 0.45
    assert metrics["min_clearance"] == min(metrics["inequalities"][name]["value_range"][0]
                                           for name in ("seabed_clearance", "panel_clearance"))
    assert metrics["max_joint_speed_ratio"] <= 1.0 + 1e-9
    assert all(entry.get("max_violation", 0.0) == 0.0 for entry in metrics["inequalities"].values())
    assert metrics["verdict"]["ok"] and metrics["verdict"]["within_inequalities"]


def test_panel_without_the_inequalities_tilts_and_comes_too_close_to_the_seabed(panel_runs):
    clik, set_based = panel_runs["clik"].metrics, panel_runs["set_based"].metrics
    assert clik["inequalities_enforced"] is False
    assert clik["max_vehicle_tilt"] > 0.12  # measured 0.1325 rad = 7.6 deg against 5
    assert clik["inequalities"]["seabed_clearance"]["max_violation"] > 0.05  # measured 6.2 cm below the 0.5 m
    assert not clik["verdict"]["within_inequalities"]
    assert any("monitored only" in warning for warning in clik["verdict"]["warnings"])
    # the same objectives were active over the same share of the run: the recorder is the solver's, not the method's
    assert set(clik["inequalities"]) == set(set_based["inequalities"])


def test_the_recorded_series_give_the_metrics(panel_runs):
    result = panel_runs["set_based"]
    simulation, inequalities = result.simulation, result.setup.inequalities
    names = [objective.name for objective in inequalities.objectives]
    assert names == ["joint_limits", "vehicle_attitude", "seabed_clearance", "panel_clearance"]
    assert simulation.objective_value.shape == (501, 4 + 1 + 1 + 1)  # four arm joints, tilt, two distances
    tilt = simulation.objective_value[:, 4]
    assert np.max(tilt) == pytest.approx(result.metrics["max_vehicle_tilt"], abs=1e-12)  # two computations agree
    attitude = result.metrics["inequalities"]["vehicle_attitude"]
    assert attitude["active_fraction"] == pytest.approx(np.mean(simulation.objective_activation[:, 4] > 0))
    assert 0.3 < attitude["active_fraction"] < 0.9  # measured 0.59: active while the vehicle pitches
    seabed = simulation.objective_value[:, 5]
    vehicle_z = np.array([result.setup.robot.base_values(q)[2] for q in simulation.q])
    assert np.abs(seabed - (vehicle_z + 6.0)).max() <= 1e-12  # the distance to z = -6
    saved = np.load(result.files[[p.name for p in result.files].index("trajectory.npz")])
    assert np.array_equal(saved["objective_value"], simulation.objective_value)


def test_non_redundant_free_floating_the_limit_wins_and_the_run_says_so(tmp_path):
    set_based = run_scenario(FREE_FLOATING, tmp_path / "sb", NO_FIGURES, progress=False).metrics
    hqp = run_scenario(FREE_FLOATING, tmp_path / "hqp", [*NO_FIGURES, "solver.method=hqp", "solver.damping_epsilon=0",
                                                "solver.damping_max=0"], progress=False).metrics
    clik = run_scenario(FREE_FLOATING, tmp_path / "clik", [*NO_FIGURES, "solver.method=clik"], progress=False).metrics
    assert clik["max_joint_limit_violation"] > 0.35  # measured: the elbow 0.40 rad past 3.5
    for metrics in (set_based, hqp):
        assert metrics["max_joint_limit_violation"] == 0.0
        assert metrics["final_position_error"] > 0.02  # measured 0.0265 (set_based), 0.0246 (hqp)
        assert metrics["max_joint_speed_ratio"] <= 1.0 + 1e-9
        assert not metrics["verdict"]["within_tolerance"]
        assert any("position error" in warning for warning in metrics["verdict"]["warnings"])
    elbow_top = set_based["inequalities"]["joint_limits"]["value_range"][1]
    assert 3.3 < elbow_top <= 3.45  # held inside the margin (3.5 - 0.05)
    assert hqp["inequalities"]["joint_limits"]["value_range"][1] <= 3.45 + 1e-9


def test_hoang2011_set_based_far_from_its_limits_is_clik_without_the_potential(tmp_path):
    """Over the first 40 s no joint is within the band: set-based = CLIK with alpha = 0, the potential run differs."""
    options = [*NO_FIGURES, "simulation.duration=40"]
    set_based = run_scenario("hoang2011_w1_set_based", tmp_path / "sb", options, progress=False)
    plain = run_scenario("hoang2011_w1", tmp_path / "clik", [*options, "solver.alpha=0"], progress=False)
    potential = run_scenario("hoang2011_w1", tmp_path / "potential", options, progress=False)
    assert set_based.metrics["inequalities"]["joint_limits"]["active_fraction"] == 0.0
    assert np.abs(set_based.simulation.q - plain.simulation.q).max() <= 1e-9  # integrated over 2000 RK4 steps
    assert np.abs(set_based.simulation.q - potential.simulation.q).max() > 0.1
    assert set_based.metrics["max_position_error"] <= 1e-9


# ------------------------------------------------------------------------------------ the scenario file
def write(tmp_path: Path, extra: str, top: str = "") -> Path:
    """The panel scenario with its [[inequalities]] replaced by ``extra`` (and ``top`` before every table)."""
    text = re.sub(r"(?ms)^\[\[inequalities\]\].*?(?=^\[solver\])", "", PANEL.read_text())
    path = tmp_path / "s.toml"
    path.write_text(top + text.replace('path = "../models', f'path = "{SCENARIOS.parent}/models') + extra)
    return path


def test_unknown_types_and_keys_are_refused_with_the_valid_ones(tmp_path):
    with pytest.raises(ScenarioError, match="close names: joint_limits") as error:
        read_scenario(write(tmp_path, '[[inequalities]]\ntype = "joint_limit"\n'))
    assert "inequalities[0]" in str(error.value)
    with pytest.raises(ScenarioError, match="close names: max_tilt"):
        read_scenario(write(tmp_path, '[[inequalities]]\ntype = "vehicle_attitude"\nmax_tlt = 0.1\n'))
    with pytest.raises(ScenarioError, match="needs frame, point, normal"):
        read_scenario(write(tmp_path, '[[inequalities]]\ntype = "plane_clearance"\n'))
    with pytest.raises(ScenarioError, match="must be finite"):
        read_scenario(write(tmp_path, '[[inequalities]]\ntype = "vehicle_attitude"\nmax_tilt = nan\n'))
    with pytest.raises(ScenarioError, match="array of tables"):
        read_scenario(write(tmp_path, "", top="inequalities = 3\n"))
    assert set(INEQUALITY_TYPES) >= {"joint_limits", "joint_velocity", "vehicle_attitude", "plane_clearance",
                                     "manipulability"}


def test_model_names_and_solver_keys_are_checked_when_built(tmp_path):
    bad_frame = '[[inequalities]]\ntype = "plane_clearance"\nframe = "jaws"\npoint = [0, 0, -6]\nnormal = [0, 0, 1]\n'
    with pytest.raises(ScenarioError, match=r"inequalities\[0\] \(plane_clearance\).*'jaws'.*vehicle"):
        run_scenario(write(tmp_path, bad_frame), tmp_path / "o", NO_FIGURES, progress=False)
    twice = '[[inequalities]]\ntype = "vehicle_attitude"\nmax_tilt = 0.1\n' * 2
    with pytest.raises(ScenarioError, match="two objectives are called 'vehicle_attitude'"):
        run_scenario(write(tmp_path, twice), tmp_path / "o", NO_FIGURES, progress=False)
    tilt = '[[inequalities]]\ntype = "vehicle_attitude"\nmax_tilt = 0.1\n'
    with pytest.raises(ScenarioError, match="joint_limits"):
        run_scenario(write(tmp_path, tilt), tmp_path / "o", [*NO_FIGURES, "solver.alpha=1"], progress=False)
    with pytest.raises(ScenarioError, match="not used by solver.method = 'hqp'"):
        run_scenario(write(tmp_path, tilt), tmp_path / "o", [*NO_FIGURES, "solver.method=hqp", "solver.eta=0.5"],
            progress=False)
    with pytest.raises(ScenarioError,
                       match=r"leaves the vehicle passive \(no actuators\).*solver.free_floating = true"):
        run_scenario(write(tmp_path, tilt), tmp_path / "o", [*NO_FIGURES, "plant.type=rigid"], progress=False)
    assert not (tmp_path / "o").exists()  # refused before anything is written


def test_manipulability_is_measured_and_the_cli_refuses_in_one_line(tmp_path, capsys):
    extra = '[[inequalities]]\ntype = "manipulability"\nframe = "ee"\nmin = 0.001\nband = 0.002\n'
    metrics = run_scenario(write(tmp_path, extra), tmp_path / "m", [*NO_FIGURES, "trajectory.duration=2",
                                                           "trajectory.accel_time=0.5"], progress=False).metrics
    entry = metrics["inequalities"]["manipulability(ee)"]
    assert metrics["min_manipulability"] == entry["value_range"][0] > 0.001
    assert entry["type"] == "manipulability" and entry["level"] == 0
    path = write(tmp_path, '[[inequalities]]\ntype = "clearance"\n')
    assert main(["run", str(path), "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "unknown inequality type 'clearance'" in err[0] and "plane_clearance" in err[0]


def test_a_run_folder_has_the_inequality_figure(tmp_path):
    result = run_scenario(PANEL, tmp_path / "f", ["trajectory.duration=2", "trajectory.accel_time=0.5"], progress=False)
    assert (tmp_path / "f" / "inequalities.png").stat().st_size > 20_000
    assert json.loads((tmp_path / "f" / "metrics.json").read_text())["inequalities"]["vehicle_attitude"]["level"] == 2
    assert tmp_path / "f" / "inequalities.png" in result.files


def test_the_recorder_takes_the_solvers_activity_and_measures_the_rest_itself():
    """ObjectiveRecorder: an objective is active as the solver's result says (its ``activity``: e.g. a QP row binding
    inside the band-free damper), else as its own activation at the row's q; values and activations are its own."""
    from types import SimpleNamespace

    from uvms.scenario.inequalities import ObjectiveRecorder, ScenarioInequalities
    from uvms.tasks.objectives import PlaneClearance, VehicleAttitude

    from conftest import shipped

    robot = shipped("bluerov2_alpha5")
    q = robot.configuration(base=[0, 0, -5, 0.15, 0.0, 0.3], arm=[3.0, 1.5, 3.4, 3.0, 0.007])  # tilted 0.15 rad
    tilt, floor = VehicleAttitude(robot, 0.1), PlaneClearance(robot, "vehicle", [0, 0, -9], [0, 0, 1], min=0.5)
    recorder = ObjectiveRecorder(robot, ScenarioInequalities([[tilt], [floor]], ["vehicle_attitude", "plane_clearance"],
                                                             enforced=True))
    rate = (np.zeros(robot.nv),)
    alone = recorder(0.0, q, None, SimpleNamespace(rate=rate, info=None))
    assert alone["objective_active"] == [True, False]  # the tilt is past its 0.1 rad, the floor 4 m away
    assert alone["objective_value"] == pytest.approx([0.15, 4.0], abs=1e-9)
    solver = SimpleNamespace(activity={floor.name: True, tilt.name: False})  # what a solver reported
    told = recorder(0.0, q, None, SimpleNamespace(rate=rate, info=solver))
    assert told["objective_active"] == [False, True]
    assert told["objective_value"] == alone["objective_value"]
    assert told["objective_activation"] == alone["objective_activation"] == [1.0, 0.0]


def test_the_recorders_speed_ratio_is_the_fastest_joint_over_its_limit_and_zero_without_limits():
    """ObjectiveRecorder.row: speed_ratio = max_i |v_i| / max_i over the limited velocities (the vehicle's free),
    0 without a speed limit; an objective is active when an activation of its rows is > 0."""
    from uvms.scenario.inequalities import ObjectiveRecorder, ScenarioInequalities
    from uvms.sim.loop import gathered
    from uvms.tasks.objectives import JointVelocityLimits, VehicleAttitude

    from conftest import shipped

    robot = shipped("bluerov2_alpha5")
    q = robot.configuration(base=[0, 0, -5, 0.15, 0.0, 0.3], arm=[3.0, 1.5, 3.4, 3.0, 0.007])  # tilted 0.15 rad
    tilt = VehicleAttitude(robot, 0.1)
    v = np.zeros(robot.nv)
    v[0], v[7] = 5.0, -0.9  # the vehicle fast (not limited), the second arm joint at 0.9 rad/s
    limited = ObjectiveRecorder(robot, ScenarioInequalities([[tilt], [JointVelocityLimits(robot, max=0.5)]],
                                                            ["vehicle_attitude", "joint_velocity"], enforced=False))
    row = limited.row(q, v)
    assert row["speed_ratio"] == pytest.approx(1.8, rel=1e-12)
    assert row["objective_active"] == [True] and row["objective_activation"] == [1.0]  # floats: the loop stacks them
    unlimited = ObjectiveRecorder(robot, ScenarioInequalities([[tilt]], ["vehicle_attitude"], enforced=False))
    assert unlimited.row(q, v)["speed_ratio"] == 0.0
    # only a speed limit: no objective with rows, the loop's series still (N, 0) of float, bool and int
    speeds = ObjectiveRecorder(robot, ScenarioInequalities([[JointVelocityLimits(robot, max=0.5)]], ["joint_velocity"],
                                                           enforced=False))
    series = gathered([speeds.row(q, v), speeds.row(q, v)])
    assert series["speed_ratio"].tolist() == pytest.approx([1.8, 1.8], rel=1e-12)
    assert [(series[name].shape, series[name].dtype.kind) for name in
            ("objective_value", "objective_activation", "objective_active", "objective_pair")] == \
        [((2, 0), "f"), ((2, 0), "f"), ((2, 0), "b"), ((2, 0), "i")]
    rows = gathered([limited.row(q, v), limited.row(q, v)])  # with the tilt: its floats and bools stacked
    assert rows["objective_active"].dtype == bool and rows["objective_activation"].tolist() == [[1.0], [1.0]]
