"""The run record (uvms.scenario.record): a run folder records its model, `uvms view --result` replays it on
that model and refuses one that contradicts it; an older run without a record still works."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import pytest

from uvms.cli import main, view_robot
from uvms.errors import RunRecordError
from uvms.scenario import run_scenario
from uvms.scenario.record import read_run_record
from uvms.scenario.resources import SCENARIOS_DIR

from conftest import NO_FIGURES, one_line, shipped


def view_options(result: Path, model: str | None = None, args: list[str] | None = None) -> argparse.Namespace:
    return argparse.Namespace(model=model, result=str(result), arg=args, base=None, package_path=[], ee=None,
                              arm_joints=None)


@pytest.fixture(scope="module")
def long_arm_run(tmp_path_factory) -> Path:
    """hoang2011 with l1 = 0.7 m (default 0.4 m), two seconds."""
    folder = tmp_path_factory.mktemp("runs") / "long_arm"
    run_scenario("hoang2011_w1_euler", out=folder, progress=False,
        overrides=[*NO_FIGURES, "model.args.l1=0.7", "simulation.duration=2"])
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
    for argv in (["view", "hoang2011"], ["view", str(SCENARIOS_DIR / "hoang2011_w1_euler.toml")],
                 ["view", "--arg", "l1=0.5"]):
        assert main([*argv, "--result", str(long_arm_run), "--headless", png]) == 2
        err = one_line(capsys)
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
    assert "uvms view needs the model" in one_line(capsys)
    metrics["model"] = {"source": "hoang2011", "args": {"l1": [1]}, "base": "planar"}
    (folder / "metrics.json").write_text(json.dumps(metrics))
    with pytest.raises(RunRecordError, match="args must map names to numbers"):
        read_run_record(folder)
