"""Watching a run (uvms.scenario.watch): edit the URDF and see it: `uvms run --watch` reruns on a change, survives a
broken edit, stops on Ctrl-C."""

from __future__ import annotations

import json
import queue
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import uvms.scenario.watch
from uvms.scenario.watch import WatchedFiles, compare

from conftest import ROOT


def copy_hoang2011(folder: Path) -> tuple[Path, Path]:
    (folder / "models").mkdir()
    (folder / "scenarios").mkdir()
    model = folder / "models" / "uvms.urdf.xacro"
    shutil.copy(ROOT / "models" / "hoang2011" / "uvms.urdf.xacro", model)
    text = (ROOT / "scenarios" / "hoang2011_w1.toml").read_text()
    scenario = folder / "scenarios" / "w1.toml"
    scenario.write_text(text.replace('path = "../models/hoang2011/uvms.urdf.xacro"',
                                     'path = "../models/uvms.urdf.xacro"'))
    assert "../models/uvms.urdf.xacro" in scenario.read_text()
    return scenario, model


def lines_of(stream, sink: queue.Queue) -> None:
    for line in stream:
        sink.put(line.rstrip("\n"))


def wait_for(lines: queue.Queue, needle: str, seconds: float = 60.0) -> str:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        try:
            line = lines.get(timeout=max(deadline - time.monotonic(), 0.01))
        except queue.Empty:
            break
        if needle in line:
            return line
    raise AssertionError(f"no line with {needle!r} within {seconds} s")


def test_run_watch_reruns_on_an_edit_keeps_the_last_good_run_and_stops_on_ctrl_c(tmp_path):
    scenario, model = copy_hoang2011(tmp_path)
    out = tmp_path / "out" / "w1"
    watcher = subprocess.Popen([sys.executable, "-m", "uvms.cli", "run", str(scenario), "--watch", "--out", str(out),
                                "--set", "simulation.duration=8"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True, cwd=tmp_path)
    lines: queue.Queue = queue.Queue()
    threading.Thread(target=lines_of, args=(watcher.stdout, lines), daemon=True).start()
    try:
        first = wait_for(lines, "first run")
        assert "max_position_error" in first and "→" not in first
        before = json.loads((out / "metrics.json").read_text())
        model.write_text(model.read_text().replace('<xacro:arg name="l1" default="0.4"/>',
                                                   '<xacro:arg name="l1" default="0.6"/>'))
        saved = time.monotonic()
        changed = wait_for(lines, "uvms.urdf.xacro changed")
        latency = time.monotonic() - saved
        assert "→" in changed and "arm_travel" in changed and str(out) in changed
        after = json.loads((out / "metrics.json").read_text())
        assert after["arm_travel"] != before["arm_travel"] and after["initial_configuration"] != before[
            "initial_configuration"]
        model.write_text("<robot name='broken'><link name='a'></robot>")  # malformed XML
        broken = wait_for(lines, "uvms.urdf.xacro changed")
        assert "malformed XML" in broken and "last good result stays" in broken
        assert json.loads((out / "metrics.json").read_text()) == after
        watcher.send_signal(signal.SIGINT)
        assert watcher.wait(timeout=20) == 130
        stderr = watcher.stderr.read()
        assert stderr.count("\n") == 1 and "stopped watching" in stderr
        assert latency < 45
    finally:
        if watcher.poll() is None:
            watcher.kill()


def test_watched_files_are_the_model_its_includes_and_data_not_the_outputs(tmp_path):
    (tmp_path / "part.xacro").write_text('<robot xmlns:xacro="http://www.ros.org/wiki/xacro"><link name="p"/></robot>')
    main = tmp_path / "rov.urdf.xacro"
    main.write_text('<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro"><xacro:include filename="part.xacro"/>'
                    '<xacro:include filename="$(find other)/x.xacro"/><link name="a"/></robot>')
    watched = WatchedFiles.of(model=main, ignore=[tmp_path / "out"])
    assert {p.name for p in watched.files} == {"rov.urdf.xacro", "part.xacro"}
    assert watched.wants(tmp_path / "hydrodynamics.yaml") and watched.wants(tmp_path / "meshes" / "hull.stl")
    assert not watched.wants(tmp_path / "out" / "metrics.json") and not watched.wants(tmp_path / "notes.txt")
    assert not watched.wants(tmp_path / ".rov.uvms-tmp-abc" / "x.urdf")


def test_watch_api_calls_back_on_a_change(tmp_path):
    model = tmp_path / "arm.urdf"
    model.write_text('<robot name="r"><link name="a"/></robot>')
    seen: list[list[Path]] = []
    thread = threading.Thread(target=uvms.scenario.watch.watch, args=(model, seen.append), kwargs={"once": True},
                              daemon=True)
    thread.start()
    time.sleep(0.5)
    model.write_text('<robot name="r"><link name="b"/></robot>')
    thread.join(timeout=20)
    assert seen and seen[0][0].name == "arm.urdf"


def test_compare_line():
    assert compare({"arm_travel": 24.6}, {"arm_travel": 26.6, "volume left_ee": 0.9}) == \
        "arm_travel 24.6 → 26.6 rad, volume left_ee 0.9 m^3"


def test_a_watched_run_that_warns_says_so_under_its_line(tmp_path):
    """A good run's terminal warnings (error above tolerance) are not swallowed by --watch."""
    from uvms.scenario.watch import Rerun

    out = tmp_path / "run"
    lines: list[str] = []
    rerun = Rerun(["run", "hoang2011_w1", "--out", str(out), "--quiet", "--set", "outputs.figures=false",
                   "--set", "trajectory.duration=10", "--set", "outputs.position_tolerance=1e-15"], out,
                  watched=lambda: None, say=lines.append)
    rerun.start("first run")
    rerun.process.wait(timeout=120)
    rerun.poll()
    assert "first run" in lines[0] and "max_position_error" in lines[0]
    assert any(line.strip().startswith("uvms: warning: hoang2011_w1:") and "position_tolerance" in line
               for line in lines[1:]), lines
