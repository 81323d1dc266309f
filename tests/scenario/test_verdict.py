"""The verdict of a run (uvms.scenario.verdict): joint limits left and a task error above the tolerance are
said on the terminal and in metrics.json; rounding at a limit is not a violation."""

from __future__ import annotations

import json

import pytest

from uvms.cli import main
from uvms.errors import ScenarioError
from uvms.scenario import run_scenario
from uvms.scenario.spec import OutputsSpec
from uvms.scenario.verdict import LIMIT_SLACK, run_verdict


def test_a_run_that_leaves_its_joint_limits_says_so_on_the_terminal(tmp_path, capsys):
    assert main(["run", "hoang2011_w1_euler", "--out", str(tmp_path / "lim"), "--quiet",  # the result line
                 "--set", "outputs.figures=false", "--set", "model.args.q23_max=0.6",
                 "--set", "model.args.q23_min=-0.6", "--set", "solver.alpha=0",
                 "--set", "simulation.duration=30"]) == 0
    captured = capsys.readouterr()
    assert captured.out == f"hoang2011_w1_euler: WARNING: joint limits left -> {tmp_path / 'lim'}/\n"
    assert captured.err.startswith("uvms: warning: hoang2011_w1_euler: the arm left its joint limits by up to")
    verdict = json.loads((tmp_path / "lim" / "metrics.json").read_text())["verdict"]
    assert verdict["ok"] is False and verdict["within_joint_limits"] is False and verdict["within_tolerance"]


def test_a_task_error_above_the_stated_tolerance_says_so_and_the_default_passes_a_good_run(tmp_path, capsys):
    assert main(["run", "hoang2011_w1_euler", "--out", str(tmp_path / "a"), "--set",
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
    tolerances = OutputsSpec(position_tolerance=0.01, orientation_tolerance=0.0175)
    assert run_verdict({**base, "max_joint_limit_violation": 3.4e-11}, tolerances)["ok"]  # xiang2019_grip's
    assert not run_verdict({**base, "max_joint_limit_violation": 10 * LIMIT_SLACK}, tolerances)["ok"]
    assert not run_verdict({**base, "max_joint_limit_violation": 0.0, "max_orientation_error": 0.02},
                           tolerances)["within_tolerance"]
