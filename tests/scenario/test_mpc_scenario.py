"""The whole-body MPC as a scenario's controller: the [controller] section (its keys MPCSettings' fields, its
refusals; no Crocoddyl needed), the error without the mpc extra, and short MPC runs through ``uvms run`` whose
metrics are recomputed from the recorded trajectory (those skip without Crocoddyl)."""

from __future__ import annotations

import dataclasses
import json
import sys

import numpy as np
import pytest

from uvms.cli import main
from uvms.control.mpc.settings import INTEGRATORS, SOLVERS, MPCSettings
from uvms.errors import ScenarioError
from uvms.robot.configuration import Configuration
from uvms.scenario import read_scenario
from uvms.scenario.build import build
from uvms.scenario.controllers import CONTROLLERS
from uvms.scenario.spec import SECTIONS, ControllerSpec, controller_types
from uvms.scenario.spec.controller import settings_docs

from conftest import SCENARIOS, one_line

MPC_SCENARIO = SCENARIOS / "bluerov2_alpha5_intervention_mpc.toml"
#: The set-based scenarios on the actuated plant, as bench_mpc.py runs them.
ACTUATED = ["plant.type=hydrodynamic", "plant.thrusters=true", "plant.gravity=true", "simulation.dt=0.01",
            "simulation.integrator=rk4"]


def needs_crocoddyl():
    pytest.importorskip("crocoddyl", reason="the mpc extra (Crocoddyl) is not installed")
    pytest.importorskip("mim_solvers", reason="the mpc extra (mim-solvers) is not installed")


# ------------------------------------------------------------------ the section (no Crocoddyl)
def test_the_keys_are_the_mpc_settings_fields_with_their_defaults_and_meanings():
    keys = ControllerSpec.keys()
    fields = dataclasses.fields(MPCSettings)
    assert list(keys) == ["type", *(item.name for item in fields)]
    assert SECTIONS["controller"] is ControllerSpec
    for item in fields:
        assert keys[item.name].default == item.default, item.name
        assert keys[item.name].doc.startswith("`mpc`: ") and len(keys[item.name].doc) > 20, item.name
    assert keys["type"].default == "solver" and controller_types(CONTROLLERS) == ("solver", "mpc")
    assert keys["solver"].allowed == SOLVERS and keys["integrator"].allowed == INTEGRATORS
    assert keys["horizon"].kinds is int and keys["knows_current"].kinds is bool and float in keys["node_dt"].kinds
    assert ControllerSpec.from_table({}, "controller", "x").settings == MPCSettings()
    assert "weight [1/m^2] of the end effector's position error" in keys["end_effector"].doc
    assert keys["vehicle_position"].doc == keys["vehicle_attitude"].doc  # "a, b: text" gives both the text


def test_the_docstring_reader_splits_shared_and_joined_entries():
    @dataclasses.dataclass
    class Example:
        """Example.

        Attributes:
            a, b: both; the same
                text, continued.
            c: one thing; d: another (``x``).
        """

        a: int = 0
        b: int = 0
        c: int = 0
        d: int = 0

    assert settings_docs(Example) == {"a": "both; the same text, continued.", "b": "both; the same text, continued.",
                                      "c": "one thing", "d": "another (``x``)."}


def test_the_scenario_gives_the_mpc_its_settings():
    spec = read_scenario(MPC_SCENARIO)
    assert spec.controller.type == "mpc"
    assert spec.controller.settings == MPCSettings(horizon=10, node_dt=0.1, solver="csqp", iterations=1,
                                                   control_period=0.05)
    spec = read_scenario(MPC_SCENARIO, ["controller.node_dt=1", "controller.iterations=2",
                                        "controller.solver=box_fddp", "controller.knows_current=true"])
    settings = spec.controller.settings
    assert settings.node_dt == 1.0 and isinstance(settings.node_dt, float) and settings.iterations == 2
    assert settings.solver == "box_fddp" and settings.knows_current is True
    assert read_scenario(SCENARIOS / "bluerov2_alpha5_intervention.toml").controller.type == "solver"


@pytest.mark.parametrize(("scenario", "overrides", "message"), [
    ("hoang2011_w1", ["controller.type=mpc"],
     r"controller.type = 'mpc' commands the thrusters.*needs plant.type = 'hydrodynamic' and plant.thrusters = true, "
     r"got plant.type = 'kinematic' and plant.thrusters = false"),
    ("bluerov2_alpha5_intervention_mpc", ["plant.thrusters=false"], r"plant.thrusters = false"),
    ("bluerov2_alpha5_intervention_mpc", ["plant.type=rigid", "plant.gravity=false", "plant.current=[]"],
     r"got plant.type = 'rigid'"),
    ("bluerov2_alpha5_intervention", ["controller.horizon=5"],
     r"controller.horizon is a setting of the MPC; it needs controller.type = 'mpc' \(got 'solver'\)"),
    ("bluerov2_alpha5_intervention_mpc", ["controller.horizon=0"], r"horizon must be an integer >= 1"),
    ("bluerov2_alpha5_intervention_mpc", ["controller.horizon=2.5"], r"controller.horizon must be a number"),
    ("bluerov2_alpha5_intervention_mpc", ["controller.node_dt=0"], r"node_dt must be > 0"),
    ("bluerov2_alpha5_intervention_mpc", ["controller.thrust=-1"], r"thrust must be a finite number >= 0"),
    ("bluerov2_alpha5_intervention_mpc", ["controller.solver='ipopt'"], r"valid: 'csqp', 'box_fddp'"),
    ("bluerov2_alpha5_intervention_mpc", ["controller.type='nmpc'"], r"valid: 'solver', 'mpc'"),
    ("bluerov2_alpha5_intervention_mpc", ["controller.control_period=0.015"],
     r"control_period must be 0 \(a solve at every step\) or a multiple of simulation.dt = 0.01 s"),
    ("bluerov2_alpha5_intervention_mpc", ["task.axes=[]"], r"task.axes = \['x', 'y', 'z'\], got all six"),
    ("bluerov2_excitation", ["controller.type=mpc"], r"excitation.wrench drives the thrusters open loop"),
    ("bluerov2_alpha5_intervention_mpc", ["controller.speed=1"], r"valid in \[controller\]: type, horizon"),
])
def test_a_controller_that_cannot_run_is_refused_when_read(scenario, overrides, message):
    with pytest.raises(ScenarioError, match=message):
        read_scenario(scenario, overrides)


def test_the_cli_refuses_in_one_line_before_writing(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["run", "hoang2011_w1", "--out", str(out), "--set", "controller.type=mpc"]) == 2
    assert "needs plant.type = 'hydrodynamic' and plant.thrusters = true" in one_line(capsys)
    assert not out.exists()


def test_without_the_mpc_extra_the_run_names_it_in_one_line(tmp_path, capsys, monkeypatch):
    for name in ("crocoddyl", "mim_solvers"):  # as if not installed (None in sys.modules: the import fails)
        monkeypatch.setitem(sys.modules, name, None)
    out = tmp_path / "out"
    assert main(["run", str(MPC_SCENARIO), "--out", str(out), "--quiet"]) == 2
    line = one_line(capsys)
    assert "controller.type = 'mpc'" in line and "pip install 'uvms[mpc]'" in line
    assert not out.exists()


# ------------------------------------------------------------------ runs (Crocoddyl)
def test_a_short_mpc_run_records_what_the_trajectory_shows(tmp_path):
    """The pipe on the actuated plant with --set controller.type=mpc: the task error, the distance to the pipe and
    the thrusts recomputed from trajectory.npz and actuation.npz; the figures drawn."""
    needs_crocoddyl()
    overrides = [*ACTUATED, "controller.type=mpc", "controller.horizon=5", "controller.node_dt=0.1",
                 "simulation.duration=0.5"]
    out = tmp_path / "pipe"
    assert main(["run", "bluerov2_alpha5_pipe", "--out", str(out), "--quiet",
                 *(item for override in overrides for item in ("--set", override))]) == 0
    metrics = json.loads((out / "metrics.json").read_text())
    recorded, actuation = np.load(out / "trajectory.npz"), np.load(out / "actuation.npz")
    setup = build(read_scenario("bluerov2_alpha5_pipe", overrides))
    robot, frame = setup.robot, setup.task.frame
    t, q = recorded["t"], recorded["q"]
    assert t[-1] == pytest.approx(0.5) and len(t) == 51
    error = [np.linalg.norm(robot.fk(qk, frame).translation - setup.trajectory(tk).pose.translation)
             for tk, qk in zip(t, q)]
    assert metrics["max_position_error"] == pytest.approx(max(error), rel=1e-9)
    assert 1e-4 < metrics["max_position_error"] < 0.02  # it follows the line, from 0 at the start
    pipe = next(item for item in setup.inequalities.objectives if item.name == "pipe")
    state = Configuration(robot, setup.q0)
    distances = []
    for qk in q:
        state.update(qk)
        distances.append(float(np.min(pipe.value(state))))
    assert metrics["min_obstacle_distance"] == pytest.approx(min(distances), rel=1e-9)
    assert metrics["inequalities"]["pipe"]["value_range"][0] == pytest.approx(min(distances), rel=1e-9)
    assert min(distances) > 0.02  # the pipe's minimum
    thrusters = setup.actuation.thrusters
    thrusts = actuation["thrusts"]
    assert np.all(thrusts <= thrusters.upper + 1e-9) and np.all(thrusts >= thrusters.lower - 1e-9)
    ratio = np.max(np.abs(thrusts) / np.where(thrusts >= 0, thrusters.upper, -thrusters.lower))
    assert metrics["max_thrust_ratio"] == pytest.approx(ratio, rel=1e-9)
    mpc = metrics["mpc"]  # a solve every 0.05 s: t = 0, 0.05, ..., 0.5 (the last row's command too)
    assert metrics["controller"] == "mpc" and "coordination" not in metrics
    assert mpc["solves"] == 11 and mpc["iterations_mean"] == 1.0 and mpc["nodes"] == 5
    assert mpc["horizon"] == pytest.approx(0.5) and mpc["solver"] == "csqp"
    assert 0 < mpc["solve_time_median"] <= mpc["solve_time_p99"] <= mpc["solve_time_max"] < 5.0
    assert {"errors.png", "thrusters.png", "inequalities.png"} <= {path.name for path in out.iterdir()}


def test_the_shipped_mpc_scenario_runs(tmp_path):
    needs_crocoddyl()
    out = tmp_path / "mpc"
    assert main(["run", str(MPC_SCENARIO), "--out", str(out), "--quiet", "--set", "simulation.duration=0.3",
                 "--set", "outputs.figures=false"]) == 0
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["verdict"]["ok"] and metrics["inequalities_enforced"] is True
    assert set(metrics["inequalities"]) == {"joint_limits", "jaw_limits", "vehicle_attitude", "seabed_clearance"}
    # the whole run's peak is in these 0.3 s (at 0.17 s, the thrusters rising from rest, the current unknown):
    # 0.29 cm (0.89 cm with the lag compensation aimed at the period's end and a filtered first estimate)
    assert 0.002 < metrics["max_position_error"] < 0.004
