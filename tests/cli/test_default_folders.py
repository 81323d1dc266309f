"""Where ``uvms workspace`` and ``uvms identify`` write without ``--out``: ``out/<command>_<robot name>``, and only
when the robot name (read from the model file) is a plain name; a name that is a path is refused in one line."""

from __future__ import annotations

import json

import pytest

import uvms
from uvms.cli import main

from conftest import FIXED_ARM, FLOATING_ROOT, one_line, urdf

ESCAPING = "x/../../../important_run"


def test_workspace_writes_into_out_under_the_robot_name(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    model = tmp_path / "arm.urdf"
    model.write_text(FIXED_ARM)
    assert main(["workspace", str(model), "-n", "10", "--quiet"]) == 0
    assert json.loads((tmp_path / "out" / "workspace_arm" / "metrics.json").read_text())["samples"] == 10


def test_a_robot_name_that_is_a_path_never_chooses_the_folder(tmp_path, monkeypatch, capsys):
    """The downloaded model of the issue: its name led three folders up and replaced the user's run."""
    work = tmp_path / "work"
    work.mkdir()
    (work / "out" / "workspace_x").mkdir(parents=True)  # where the old path went through
    model = work / "evil.urdf"
    model.write_text(FIXED_ARM.replace('<robot name="arm">', f'<robot name="{ESCAPING}">'))
    important = tmp_path / "important_run"
    assert main(["workspace", str(model), "-n", "20", "--quiet", "--out", str(important)]) == 0  # the user's run
    before = (important / "metrics.json").read_text()
    capsys.readouterr()
    monkeypatch.chdir(work)
    assert main(["workspace", str(model), "-n", "10", "--quiet"]) == 2
    err = one_line(capsys)
    assert repr(ESCAPING) in err and "pass --out DIR" in err
    assert (important / "metrics.json").read_text() == before and json.loads(before)["samples"] == 20
    assert not (tmp_path / "out").exists() and sorted(p.name for p in (work / "out").iterdir()) == ["workspace_x"]
    assert main(["workspace", str(model), "-n", "10", "--quiet", "--out", "mine"]) == 0  # --out: the user's choice
    assert json.loads((work / "mine" / "metrics.json").read_text())["samples"] == 10


def test_identify_refuses_the_same_name(tmp_path, monkeypatch, capsys):
    """The default folder of ``uvms identify`` (the identification itself stubbed: it is not under test)."""
    import uvms.cli.identify as command
    from uvms.dynamics.hydro import hydrodynamics
    from uvms.dynamics.identification import identify as identification

    model = tmp_path / "evil.urdf"
    model.write_text(urdf(root=FLOATING_ROOT).replace('<robot name="probe">', f'<robot name="{ESCAPING}">'))
    monkeypatch.setattr(command, "read_log", lambda options, robot: None)
    monkeypatch.setattr(hydrodynamics, "hydrodynamics_of", lambda robot, prior: None)
    monkeypatch.setattr(identification, "identify", lambda *args, **kwargs: None)
    monkeypatch.chdir(tmp_path)
    assert main(["identify", str(tmp_path / "log.csv"), "--model", str(model)]) == 2
    err = one_line(capsys)
    assert repr(ESCAPING) in err and "out/identify_<name>" in err and "pass --out DIR" in err
    assert not (tmp_path / "out").exists() and not (tmp_path.parent / "important_run").exists()


@pytest.mark.parametrize("name", ["arm", "rexrov-2.v1"])
def test_plain_robot_names_keep_their_folder(name):
    from uvms.io.names import default_output_folder

    assert str(default_output_folder("workspace", uvms.load(FIXED_ARM.replace('"arm"', f'"{name}"')).name)) == \
        f"out/workspace_{name}"


def test_identify_refuses_a_folder_before_it_fits(tmp_path, monkeypatch, capsys):
    """An output folder that holds the log is refused before the (seconds-long) identification runs, and leaves no
    lock: the fit is never called."""
    import uvms.cli.identify as command
    from uvms.dynamics.hydro import hydrodynamics
    from uvms.dynamics.identification import identify as identification

    def never(*args, **kwargs):
        raise AssertionError("the identification ran before the output folder was checked")

    run = tmp_path / "run"
    (run / "bag").mkdir(parents=True)
    monkeypatch.setattr(command, "read_log", lambda options, robot: None)
    monkeypatch.setattr(hydrodynamics, "hydrodynamics_of", lambda robot, prior: None)
    monkeypatch.setattr(identification, "identify", never)
    assert main(["identify", str(run / "bag"), "--model", "bluerov2_alpha5", "--out", str(run)]) == 2
    assert "uvms: error: " in one_line(capsys)
    assert sorted(path.name for path in run.iterdir()) == ["bag"]
