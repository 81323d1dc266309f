"""``--package-path DIR`` of ``uvms run``, ``uvms sweep`` and ``uvms view`` (uvms.cli.run, uvms.cli.view): the
folders given come before the scenario's own ``[model] package_path``, and a run folder replays on them."""

from __future__ import annotations

import contextlib
import csv
import os
import shutil

import numpy as np
import pytest

from uvms.cli import main
from uvms.errors import MissingMeshWarning
from uvms.scenario import read_run_record

from conftest import ROS_SHORT_RUN, ROS_WORKSPACE


@pytest.fixture
def scenario(tmp_path, monkeypatch):
    """The fixture's vehicle away from its workspace, in a scenario whose own package folder ``arms`` holds an arm
    package of the same name with other lengths (0.5 m and 0.1 m)."""
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)
    monkeypatch.chdir(tmp_path)
    shutil.copy(ROS_WORKSPACE / "fixture_vehicle_description" / "urdf" / "vehicle.urdf.xacro", tmp_path)
    arm = shutil.copytree(ROS_WORKSPACE / "fixture_arm", tmp_path / "arms" / "other_arm")
    (arm / "urdf" / "arm.xacro").write_text((arm / "urdf" / "arm.xacro").read_text()
                                            .replace('value="0.35"', 'value="0.5"')
                                            .replace('value="0.25"', 'value="0.1"'))
    path = tmp_path / "s.toml"
    path.write_text(ROS_SHORT_RUN.format(package_path='package_path = ["arms"]'))
    return path


def ee_at_start(folder) -> np.ndarray:
    """The end effector of a run folder's recorded model at the run's first configuration [m]."""
    robot = read_run_record(folder).load()
    return robot.fk(np.load(folder / "trajectory.npz")["q"][0], "ee").translation


def test_run_puts_the_folders_given_before_the_scenario_s_own(scenario, capsys):
    shoulder, elbow = 0.3, -0.4  # q1 and q1 + q2 of the initial arm; the vehicle starts at the origin
    for given, lengths in (([], (0.5, 0.1)),
                           (["--package-path", os.path.relpath(ROS_WORKSPACE)], (0.35, 0.25))):  # from the cwd
        out = scenario.parent / f"out{len(given)}"
        assert main(["run", str(scenario), "--out", str(out), "--quiet", *given]) == 0, capsys.readouterr().err
        expected = [0.5 + lengths[0] * np.cos(shoulder) + lengths[1] * np.cos(elbow),
                    lengths[0] * np.sin(shoulder) + lengths[1] * np.sin(elbow), -0.2]
        with pytest.warns(MissingMeshWarning) if not given else contextlib.nullcontext():  # the vehicle's meshes
            start = ee_at_start(out)  # are in its package, in ROS_WORKSPACE only
        np.testing.assert_allclose(start, expected, atol=1e-12)
    assert read_run_record(out).package_path == [str(ROS_WORKSPACE), str(scenario.parent / "arms")]
    capsys.readouterr()
    assert main(["view", "--result", str(out), "--headless", str(scenario.parent / "replay.png")]) == 0
    assert (scenario.parent / "replay.png").stat().st_size > 0


def test_run_reads_the_scenario_once(scenario, capsys, monkeypatch):
    """``uvms run`` with --set and --package-path reads the scenario file once (it read it three times)."""
    from uvms.scenario import schema

    reads = []
    read_toml = schema.read_toml
    monkeypatch.setattr(schema, "read_toml", lambda path: reads.append(path) or read_toml(path))
    assert main(["run", str(scenario), "--out", str(scenario.parent / "once"), "--quiet", "--set",
                 "outputs.figures=false", "--package-path", str(ROS_WORKSPACE)]) == 0, capsys.readouterr().err
    assert len(reads) == 1
    assert read_run_record(scenario.parent / "once").package_path == [str(ROS_WORKSPACE),
                                                                      str(scenario.parent / "arms")]


def test_sweep_and_view_take_package_folders_too(scenario, capsys):
    out = scenario.parent / "sweep"
    assert main(["sweep", str(scenario), "--grid", "simulation.dt=[0.1, 0.2]", "--package-path",
                 str(ROS_WORKSPACE), "--out", str(out), "--quiet"]) == 0, capsys.readouterr().err
    with open(out / "sweep.csv") as table:
        rows = list(csv.DictReader(table))
    assert [row["error"] for row in rows] == ["", ""]
    assert read_run_record(out / "point_0").package_path[0] == str(ROS_WORKSPACE)
    model = scenario.parent / "vehicle.urdf.xacro"
    picture = scenario.parent / "vehicle.png"
    assert main(["view", str(model), "--headless", str(picture)]) == 2  # no package named: one line
    assert "no ROS package 'fixture_arm_description'" in capsys.readouterr().err
    assert main(["view", str(model), "--package-path", str(ROS_WORKSPACE), "--headless", str(picture)]) == 0
    assert picture.stat().st_size > 0


def test_quiet_prints_the_one_result_line_and_a_rerun_says_it_replaced_the_previous_run(scenario, capsys):
    out = scenario.parent / "run"
    assert main(["run", str(scenario), "--out", str(out), "--quiet"]) == 0
    first = capsys.readouterr().out.splitlines()
    assert first == [f"s: ok: inside the joint limits, errors <= 0.01 m and 0.0175 rad -> {out}/"]
    assert main(["run", str(scenario), "--out", str(out), "--quiet"]) == 0
    assert capsys.readouterr().out.splitlines() == [first[0] + " (replaced the previous run)"]
    assert main(["run", str(scenario), "--out", str(out)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[-1] == f"replaced    the previous run in {out}/" and lines[-2].startswith(f"outputs     {out}/ (")
    assert main(["run", str(scenario), "--out", str(scenario.parent / "fresh")]) == 0
    assert not any(line.startswith("replaced") for line in capsys.readouterr().out.splitlines())


def test_the_first_line_says_what_runs_before_it_starts(scenario, capsys, monkeypatch):
    """``uvms run`` names the scenario, model, simulated time, steps, solver, plant and folder before the build and
    the loop (a run of minutes says within a second what it is doing)."""
    import uvms.scenario

    before: list[str] = []
    real = uvms.scenario.run_scenario

    def spy(*args, **kwargs):
        before.append(capsys.readouterr().out)
        return real(*args, **kwargs)

    monkeypatch.setattr(uvms.scenario, "run_scenario", spy)
    assert main(["run", str(scenario), "--set", "simulation.dt=0.05"]) == 0
    first = ("run         s: model vehicle.urdf.xacro, 0.4 s in 8 steps of 0.05 s, solver clik, kinematic plant "
             "-> out/s/\n")
    assert before == [first]
    assert capsys.readouterr().out.startswith("scenario    s  (8 steps, ")


def test_a_step_count_out_of_range_is_refused_before_the_run(scenario, capsys):
    assert main(["run", str(scenario), "--set", "simulation.dt=1e-9"]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.startswith("uvms: error: ") and "simulation.dt" in captured.err
    assert not (scenario.parent / "out").exists()
