"""Scenario names (uvms.scenario.resources): a shipped scenario runs by its name from any folder, a file of
one's own wins over a shipped name, an unknown name lists the close ones."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from uvms.cli import main, run_output_folder, scenario_file
from uvms.scenario.resources import SCENARIOS_DIR, resolve_scenario_path, shipped_scenarios

from conftest import one_line


def test_a_shipped_scenario_runs_by_name_from_any_folder(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)  # no scenarios/ here: the name is looked up in the installed repository
    assert resolve_scenario_path("hoang2011_w1") == SCENARIOS_DIR / "hoang2011_w1.toml"
    assert "santos2006_task_priority" in shipped_scenarios()
    assert main(["run", "santos2006_task_priority", "--out", "tp", "--set", "outputs.figures=false"]) == 0
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
    err = one_line(capsys)
    assert "not a shipped scenario name" in err and "close shipped scenarios: hoang2011_w1" in err
    assert main(["run", "nothing_like_it.toml"]) == 2
    assert "shipped scenarios: amundsen2018" in one_line(capsys)


def test_sweep_takes_a_scenario_name(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["sweep", "santos2006_task_priority", "--grid", "solver.gain=[1.0, 2.0]", "--out", "sw",
                 "--quiet"]) == 0
    assert "point_*" in capsys.readouterr().out
    rows = (tmp_path / "sw" / "sweep.csv").read_text().splitlines()
    assert len(rows) == 3 and rows[1].endswith(",")  # two points, no error
