"""Attacks on the output folders (uvms.io.outputs), the sweep and the terminal: each attack, and that it fails.

``--out`` never deletes what a user made: a run folder is recognised by its manifest, nothing else in it is
replaced, and never the input being run. A planted lock symlink is refused, its target untouched. A full disk
says so. Sweep workers are capped, CSV formula cells neutralised, SIGTERM/SIGHUP clean up.
(The Dask backend: tests/scenario/studies/test_sweep.py; terminal escapes: tests/cli/test_info.py.)
"""

from __future__ import annotations

import csv
import errno
import json
import os
import signal
import subprocess
import time
from pathlib import Path

import pytest

from uvms.cli import main
from uvms.errors import RunFolderError
from uvms.io import outputs
from uvms.scenario import run_scenario
from uvms.scenario.studies.sweep import SweepError, SweepResult, sweep

from conftest import NO_FIGURES, ROOT, one_line, raising, signal_a_running_sweep, uvms_command, wait_for

SANTOS = ROOT / "scenarios" / "santos2006_task_priority.toml"  # 100 Euler steps
HOANG = ROOT / "scenarios" / "hoang2011_w1.toml"  # 9,500 RK4 steps: under a second of loop on a quiet machine
#: hoang2011_w1 at a fifth of its step: 47,500 RK4 steps, a run that lasts seconds after its folder appears (a
#: signal test's window; the signal ends it long before)
LONG_RUN = ("--set", "simulation.dt=0.004")


def uvms_run_folder(folder: Path, **files: str) -> None:
    """A folder written by uvms (through run_folder: with its manifest) holding ``files``."""
    with outputs.run_folder(folder) as temporary:
        for name, text in files.items():
            (temporary / name).parent.mkdir(parents=True, exist_ok=True)
            (temporary / name).write_text(text)


def contents(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def short_hoang(folder: Path) -> Path:
    """hoang2011_w1 copied into ``folder`` with a 12 s trajectory (its model path made absolute)."""
    text = HOANG.read_text().replace('path = "../models', f'path = "{ROOT}/models').replace("duration = 190.0",
                                                                                           "duration = 12.0")
    path = folder / "my.toml"
    path.write_text(text)
    return path


# ------------------------------------------------------------------ 1. --out never deletes a user's folder
def test_a_user_folder_with_a_metrics_json_and_the_scenario_is_kept(tmp_path, monkeypatch, capsys):
    mine = tmp_path / "p"
    mine.mkdir()
    (mine / "metrics.json").write_text('{"accuracy":0.93}\n')
    (mine / "notes.txt").write_text("notes\n")
    short_hoang(mine)
    before = contents(mine)
    monkeypatch.chdir(mine)
    assert main(["run", "my.toml", "--out", ".", "--quiet"]) == 2
    err = one_line(capsys)
    assert f"'.' holds '{mine / 'my.toml'}', an input of this run" in err and "choose another --out" in err
    assert contents(mine) == before
    (tmp_path / "elsewhere.toml").write_text((mine / "my.toml").read_text())  # the scenario outside: still refused
    assert main(["run", str(tmp_path / "elsewhere.toml"), "--out", ".", "--quiet"]) == 2
    err = one_line(capsys)
    assert "holds metrics.json but no .uvms-run.json" in err
    assert "delete the folder yourself or choose another --out" in err
    assert "metrics.json, my.toml, notes.txt" in err and contents(mine) == before


def test_files_a_user_put_into_an_earlier_run_folder_are_kept(tmp_path, capsys):
    folder = tmp_path / "run"
    run_scenario(SANTOS, out=folder, overrides=NO_FIGURES, progress=False)
    manifest = json.loads((folder / outputs.MANIFEST).read_text())
    assert manifest["entries"] == ["metrics.json", "trajectory.csv", "trajectory.npz"]
    (folder / "notes.txt").write_text("what I saw")
    edited = folder / "edited.toml"
    edited.write_text(SANTOS.read_text().replace('"../models', f'"{ROOT}/models'))
    before = contents(folder)
    assert main(["run", str(edited), "--out", str(folder), "--quiet"]) == 2  # the scenario being run
    assert f"holds '{edited}', an input of this run" in one_line(capsys)
    assert main(["run", str(SANTOS), "--out", str(folder), "--quiet", "--set", "outputs.figures=false"]) == 2
    err = one_line(capsys)
    assert "holds 2 file(s) that uvms did not write there (edited.toml, notes.txt)" in err
    assert contents(folder) == before
    edited.unlink()
    (folder / "notes.txt").unlink()
    assert main(["run", str(SANTOS), "--out", str(folder), "--quiet", "--set", "outputs.figures=false"]) == 0


def test_foreign_files_anywhere_below_are_listed_a_few_then_the_count(tmp_path):
    folder = tmp_path / "sweep"
    uvms_run_folder(folder, **{"sweep.csv": "point\n", "point_0/metrics.json": "{}"})
    assert json.loads((folder / outputs.MANIFEST).read_text())["entries"] == [
        "point_0/", "point_0/metrics.json", "sweep.csv"]
    (folder / "point_0" / "notes.txt").write_text("x")
    for k in range(7):
        (folder / f"extra_{k}.txt").write_text("x")
    before = contents(folder)
    with pytest.raises(RunFolderError, match=r"holds 8 file\(s\) that uvms did not write there \(extra_0.txt, "
                                             r"extra_1.txt, extra_2.txt, extra_3.txt, extra_4.txt and 3 more\)"):
        with outputs.run_folder(folder):
            pass
    assert contents(folder) == before
    for path in [*folder.glob("extra_*"), folder / "point_0" / "notes.txt"]:
        path.unlink()
    (folder / outputs.MANIFEST).write_text("not json")  # a broken manifest is no manifest
    with pytest.raises(RunFolderError, match="holds sweep.csv but no .uvms-run.json"):
        with outputs.run_folder(folder):
            pass


def test_an_input_inside_the_folder_is_refused_even_through_a_hard_link(tmp_path):
    folder = tmp_path / "run"
    uvms_run_folder(folder, **{"metrics.json": "{}"})
    scenario = tmp_path / "my.toml"
    scenario.write_text("x")
    with pytest.raises(RunFolderError, match="is an input|holds '.*run', an input"):
        with outputs.run_folder(folder, inputs=[folder]):
            pass
    os.link(scenario, folder / "metrics.json.bak")
    manifest = json.loads((folder / outputs.MANIFEST).read_text())
    (folder / outputs.MANIFEST).write_text(json.dumps({**manifest, "entries": [*manifest["entries"],
                                                                               "metrics.json.bak"]}))
    with pytest.raises(RunFolderError, match="holds a hard link to .*my.toml', an input of this run"):
        with outputs.run_folder(folder, inputs=[scenario]):
            pass
    assert scenario.read_text() == "x"


def test_a_sweep_never_deletes_its_scenario(tmp_path):
    folder = tmp_path / "sweep"
    uvms_run_folder(folder, **{"sweep.csv": "point\n"})  # an earlier sweep...
    scenario = folder / "edited.toml"  # ...where the user keeps the scenario they edit
    scenario.write_text(SANTOS.read_text().replace('"../models', f'"{ROOT}/models'))
    with pytest.raises(RunFolderError, match="an input of this run"):
        sweep(scenario, ["solver.gain=[0.5, 1.0]"], out=folder, progress=False)
    assert scenario.is_file() and (folder / "sweep.csv").is_file()


def test_workspace_never_deletes_its_model(tmp_path, capsys):
    folder = tmp_path / "ws"
    uvms_run_folder(folder, **{"metrics.json": "{}"})
    model = folder / "arm.urdf"
    model.write_text('<robot name="arm"><link name="base"/><link name="l1"/><joint name="j1" type="revolute">'
                     '<parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>'
                     '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>')
    assert main(["workspace", str(model), "-n", "100", "--ee", "l1", "--out", str(folder), "--quiet"]) == 2
    assert "an input of this run" in one_line(capsys) and model.is_file()


def test_a_bag_folder_needs_the_manifest(tmp_path):
    from uvms.scenario.bags.writer import write_bag

    pytest.importorskip("rosbags")
    result = run_scenario(SANTOS, out=tmp_path / "run", overrides=NO_FIGURES, progress=False)
    robot, simulation = result.setup.robot, result.simulation
    old = tmp_path / "old"  # a bag of another tool or an older uvms, with the user's notes beside it
    old.mkdir()
    (old / "metadata.yaml").write_text("rosbag2_bagfile_information: {}\n")
    (old / "notes.txt").write_text("keep")
    with pytest.raises(RunFolderError, match="holds metadata.yaml but no .uvms-run.json"):
        write_bag(old, robot, simulation)
    assert sorted(p.name for p in old.iterdir()) == ["metadata.yaml", "notes.txt"]
    bag = tmp_path / "bag"
    write_bag(bag, robot, simulation)
    (bag / "notes.txt").write_text("keep")
    with pytest.raises(RunFolderError, match=r"did not write there \(notes.txt\)"):
        write_bag(bag, robot, simulation)
    (bag / "notes.txt").unlink()
    write_bag(bag, robot, simulation, start_time_ns=5)  # its own bag is replaced
    assert sorted(p.name for p in bag.iterdir()) == [outputs.MANIFEST, "bag.mcap", "metadata.yaml"]


# ------------------------------------------------------------------ 14. a planted lock symlink
def test_a_lock_that_is_a_symbolic_link_is_refused_and_its_target_untouched(tmp_path):
    victim = tmp_path / "victim"
    victim.mkdir()
    (victim / "precious").write_text("keep")
    shared = tmp_path / "shared"
    shared.mkdir()
    for name, target in (("new", victim / "created_by_the_victim"), ("old", victim / "precious")):
        (shared / f".{name}.uvms-lock").symlink_to(target)
        with pytest.raises(RunFolderError, match=f"the lock '.*/.{name}.uvms-lock' of .* is a symbolic link"):
            with outputs.run_folder(shared / name):
                pass
        assert not (shared / name).exists()
    assert not (victim / "created_by_the_victim").exists()
    assert (victim / "precious").read_text() == "keep"  # not truncated either


# ------------------------------------------------------------------ 15. a full disk
@pytest.mark.parametrize("code", [errno.ENOSPC, errno.EDQUOT], ids=["ENOSPC", "EDQUOT"])
def test_a_full_disk_says_so_and_keeps_the_previous_run(tmp_path, code):
    from uvms.errors import DiskFullError

    folder = tmp_path / "run"
    uvms_run_folder(folder, **{"metrics.json": '{"run": 1}'})
    before = contents(folder)
    with pytest.raises(DiskFullError, match=f"no space left on the device holding '{tmp_path}' "
                                            f"\\({os.strerror(code)}\\); {folder} keeps the previous complete run"):
        with outputs.run_folder(folder) as temporary:
            outputs.write_json(temporary / "metrics.json", {"run": 2})
            raise OSError(code, os.strerror(code))
    assert contents(folder) == before and not list(tmp_path.glob(".run.uvms-tmp-*"))


def test_a_full_disk_in_the_cli_is_one_line_naming_the_disk(tmp_path, monkeypatch, capsys):
    folder = tmp_path / "run"
    run_scenario(SANTOS, out=folder, overrides=NO_FIGURES, progress=False)
    before = contents(folder)

    def full(path, **arrays):
        raise OSError(errno.ENOSPC, "No space left on device", str(path))

    monkeypatch.setattr(outputs, "write_npz", full)
    assert main(["run", str(SANTOS), "--out", str(folder), "--quiet", "--set", "outputs.figures=false"]) == 2
    assert one_line(capsys) == (f"uvms: error: no space left on the device holding '{tmp_path}' (No space left on "
                                f"device); {folder} keeps the previous complete run\n")
    assert contents(folder) == before

    full_elsewhere = OSError(errno.ENOSPC, "No space left on device", "/data/cache/file.bin")  # not in a run folder
    monkeypatch.setattr("uvms.cli.command_info", raising(full_elsewhere))
    assert main(["info", "hoang2011"]) == 2
    assert one_line(capsys) == ("uvms: error: no space left on the device holding '/data/cache' "
                                "(No space left on device)\n")


# ------------------------------------------------------------------ 16. workers, CSV cells, SIGTERM/SIGHUP
def test_sweep_workers_are_capped_by_points_and_cores(tmp_path, monkeypatch):
    import joblib

    asked = []
    parallel = joblib.Parallel

    def recording(*args, **kwargs):
        asked.append(kwargs.get("n_jobs"))
        return parallel(*args, **kwargs)

    monkeypatch.setattr(joblib, "Parallel", recording)
    result = sweep(SANTOS, ["solver.gain=[0.5, 1.0]"], jobs=16, out=tmp_path / "s", progress=False)
    assert not result.failed and asked == [min(2, os.cpu_count() or 1)]
    from uvms.scenario.studies.parallel import worker_count

    assert worker_count(16, 2) == min(2, os.cpu_count() or 1) and worker_count(-1, 10**4) == (os.cpu_count() or 1)
    assert worker_count(1, 5) == 1 and worker_count(16, 2, remote=True) == 2 and worker_count(-1, 2, remote=True) == -1


@pytest.mark.filterwarnings("ignore:Glyph")  # the tab of a tick label in sweep.png
def test_formula_cells_in_sweep_csv_are_neutralised(tmp_path):
    values = ["=HYPERLINK(\"http://x\",\"y\")", "+cmd", "-2+3", "@SUM(A1)", "\tx", "plain", "a=b"]
    grid = "scenario.description=" + json.dumps(values)
    result = sweep(SANTOS, [grid], out=tmp_path / "s", progress=False)
    with open(tmp_path / "s" / "sweep.csv", newline="", encoding="utf-8") as handle:
        rows = list(csv.reader(handle))
    assert [row[1] for row in rows[1:]] == ["'" + v for v in values[:5]] + ["plain", "a=b"]
    assert all(float(row[3]) > 0 for row in rows[1:])  # numbers stay numbers
    table = SweepResult(keys=["solver.gain"], rows=[{"point": 0, "solver.gain": -0.5, "error": "-x", **{
        key: -1.5 for key in result.columns[2:-1]}}])
    assert table.csv().splitlines()[1].split(",") == ["0", "-0.5", *["-1.5"] * (len(result.columns) - 3), "'-x"]
    with pytest.raises(SweepError, match="a string value holds a line break"):  # a CR in a cell would split the row
        sweep(SANTOS, ['scenario.description=["\\rx", "b"]'], out=tmp_path / "t", progress=False)


def test_sigterm_stops_a_sweep_cleanly(tmp_path):
    folder = tmp_path / "out" / "sweep"
    child, err = signal_a_running_sweep(folder, "solver.gain=[1.0, 2.0, 3.0]", signal.SIGTERM)
    assert child.returncode == 128 + signal.SIGTERM
    assert err.splitlines() == [f"uvms: terminated by SIGTERM; nothing was written to {folder}"]
    time.sleep(0.5)
    assert not [p for p in tmp_path.rglob("*") if outputs.TEMPORARY_MARK in p.name]
    assert sorted(p.name for p in folder.parent.iterdir()) == [".sweep.uvms-lock"]


def test_sighup_stops_a_run_and_keeps_the_previous_one(tmp_path):
    folder = tmp_path / "run"
    uvms_run_folder(folder, **{"metrics.json": '{"run": 1}'})
    before = contents(folder)
    child = subprocess.Popen(uvms_command("run", str(HOANG), "--out", str(folder), "--quiet", *LONG_RUN),
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        wait_for(lambda: list(tmp_path.glob(f".run{outputs.TEMPORARY_MARK}*")), process=child)  # the run under way
        time.sleep(0.5)
        child.send_signal(signal.SIGHUP)
        out, err = child.communicate(timeout=60)
    finally:
        if child.poll() is None:
            child.kill()
            child.communicate()
    assert child.returncode == 128 + signal.SIGHUP
    assert err.splitlines() == [f"uvms: terminated by SIGHUP; {folder} keeps the previous complete run"]
    assert contents(folder) == before and not list(tmp_path.glob(f".run{outputs.TEMPORARY_MARK}*"))


def test_an_ignored_hangup_stays_ignored_under_nohup():
    from uvms.cli import stop_signals_interrupt

    previous, terminate = signal.signal(signal.SIGHUP, signal.SIG_IGN), signal.getsignal(signal.SIGTERM)
    try:
        with stop_signals_interrupt():
            assert signal.getsignal(signal.SIGHUP) is signal.SIG_IGN  # nohup uvms run ...: a hangup does not stop it
            assert signal.getsignal(signal.SIGTERM) is not terminate
        assert signal.getsignal(signal.SIGTERM) is terminate  # restored
    finally:
        signal.signal(signal.SIGHUP, previous)
