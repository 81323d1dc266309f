"""`uvms tune` (uvms.scenario.studies.tune): Optuna finds a known optimum; outputs; bad input before any trial."""

from __future__ import annotations

import json

import numpy as np
import pytest

import uvms
from uvms.errors import StudyError
from uvms.scenario.studies.tune import parse_parameter, toml_fragment, tune

from conftest import ROOT

pytest.importorskip("optuna")
ARM = [0.5, 0.8, 0.6]
OPTIMUM = 0.45  # [m] the first link for which the jaws start on the held point


def hold_scenario(folder) -> str:
    """hoang2011 holding the point its end effector has with l1 = OPTIMUM: for any l1 the initial (and largest)
    error is |l1 - OPTIMUM| exactly, the end effector moving along the first link."""
    robot = uvms.load("hoang2011", args={"l1": OPTIMUM})
    configuration = uvms.Configuration(robot, robot.configuration(base=np.zeros(3), arm=np.array(ARM)))
    point = configuration.pose(robot.model.getFrameId(robot.ee_frames[0])).translation
    path = folder / "hold.toml"
    path.write_text(f"""
[model]
path = "{ROOT / 'models' / 'hoang2011' / 'uvms.urdf.xacro'}"
[task]
axes = ["x", "y"]
[trajectory]
type = "hold"
start = {[float(v) for v in point]}
duration = 0.5
[initial]
base = [0.0, 0.0, 0.0]
arm = {ARM}
[simulation]
dt = 0.05
[outputs]
figures = false
""")
    return str(path)


def test_tpe_finds_the_known_optimum_within_a_centimetre_in_25_trials(tmp_path):
    scenario = hold_scenario(tmp_path)
    result = tune(scenario, ["model.args.l1=0.3:0.6"], objective="max_position_error", trials=25, seed=0,
                  out=tmp_path / "t")
    best = result.best
    assert abs(best["parameters"]["model.args.l1"] - OPTIMUM) < 0.01
    for row in result.rows:  # every trial's value is the closed form |l1 - OPTIMUM|
        assert row["value"] == pytest.approx(abs(row["model.args.l1"] - OPTIMUM), abs=1e-9)
    assert best["value"] == min(row["value"] for row in result.rows)
    folder = tmp_path / "t"
    assert json.loads((folder / "best.json").read_text())["set"] == \
        [f"model.args.l1={best['parameters']['model.args.l1']!r}"]
    assert (folder / "best.toml").read_text().splitlines()[1:] == ["[model.args]",
                                                                  f"l1 = {best['parameters']['model.args.l1']!r}"]
    assert (folder / "tune_history.png").read_bytes().startswith(b"\x89PNG")
    again = tune(scenario, ["model.args.l1=0.3:0.6"], objective="max_position_error", trials=5, seed=0,
                 out=tmp_path / "t2")
    assert [row["model.args.l1"] for row in again.rows] == [row["model.args.l1"] for row in result.rows[:5]]  # seeded


def test_parameters_and_fragments():
    assert parse_parameter("solver.gain=0.5:4:log") == parse_parameter(" solver.gain = 0.5:4:log ")
    assert parse_parameter("solver.gain=0.5:4").log is False
    for bad in ("solver.gain=1", "solver.gain=2:1", "solver.gain=0:1:log", "solver.gain=1:2:lin", "gain=1:2",
                "solver.gain=nan:2", "plant.current[0]=0:1"):
        with pytest.raises(StudyError, match="--param expects KEY=LOW:HIGH"):
            parse_parameter(bad)
    assert toml_fragment({"solver.gain": 2.5, "vehicle_control.bandwidth": 1.0, "solver.alpha": 3}) == (
        "[solver]\ngain = 2.5\nalpha = 3\n\n[vehicle_control]\nbandwidth = 1.0\n")


def test_bad_input_fails_before_any_trial(tmp_path):
    scenario = hold_scenario(tmp_path)
    with pytest.raises(StudyError, match="objective 'speed' is not valid; valid: max_position_error"):
        tune(scenario, ["solver.gain=0.5:2"], objective="speed", out=tmp_path / "t")
    with pytest.raises(uvms.UVMSError, match="solver.damping = -1 is out of range"):
        tune(scenario, ["solver.damping=-1:1"], out=tmp_path / "t")
    with pytest.raises(StudyError, match="valid forms"):
        tune(scenario, ["solver.gain=0.5:2"], samples=["plant.current[0]=gauss(0, 1)"], out=tmp_path / "t")
    assert not (tmp_path / "t").exists()
