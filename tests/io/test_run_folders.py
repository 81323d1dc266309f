"""Run folders (uvms.io.outputs): a run folder is replaced whole: killed, interrupted, failed or concurrent runs
never leave a mixed folder.

The subprocess tests slow the figure writer down in the child (``SLOW_CHILD``) so that they can act while a run is
writing its files, without depending on the speed of the machine.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from uvms import UVMSError
from uvms.cli import main
from uvms.errors import DiskFullError, RunFolderBusy, RunFolderError
from uvms.io import outputs
from uvms.scenario import run_scenario

from conftest import ROOT, signal_a_running_sweep, uvms_command, wait_for

SANTOS = ROOT / "scenarios" / "santos2006_task_priority.toml"  # 100 Euler steps, 6 figures
HOANG = ROOT / "scenarios" / "hoang2011_w1.toml"  # 9,500 RK4 steps: several seconds per run
RUN_FILES = {"metrics.json", "trajectory.csv", "trajectory.npz", "desired_motion.png", "vehicle.png",
             "vehicle_velocity.png", "joints.png", "errors.png", "path.png", outputs.MANIFEST}
#: `python -c SLOW_CHILD SECONDS ARGS...`: the uvms CLI with a figure writer that first sleeps SECONDS
SLOW_CHILD = """
import sys, time
import uvms.io.outputs as outputs
save_figure = outputs.save_figure
def slow(figure, path, dpi=110):
    time.sleep(float(sys.argv[1]))
    save_figure(figure, path, dpi)
outputs.save_figure = slow
from uvms.cli import main
sys.exit(main(sys.argv[2:]))
"""


def slow_child(seconds: float, *args: str, **popen) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-c", SLOW_CHILD, str(seconds), *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, **popen)


def temporaries(folder: Path) -> list[Path]:
    """The hidden temporary siblings of a run folder."""
    return sorted(folder.parent.glob(f".{folder.name}{outputs.TEMPORARY_MARK}*"))


def writing(folder: Path, name: str = "trajectory.csv"):
    """The temporary sibling of ``folder`` once the run has written ``name`` into it."""
    return lambda: [t for t in temporaries(folder) if (t / name).exists()]


def snapshot(folder: Path) -> dict[str, bytes]:
    return {path.name: path.read_bytes() for path in sorted(folder.iterdir())}


@pytest.fixture
def previous_run(tmp_path):
    """A complete santos2006 run in tmp_path/out/run, and a snapshot of it."""
    folder = tmp_path / "out" / "run"
    done = subprocess.run(uvms_command("run", str(SANTOS), "--out", str(folder), "--quiet"), capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert {path.name for path in folder.iterdir()} == RUN_FILES
    return folder, snapshot(folder)


# ------------------------------------------------------------------ the mechanism itself
def test_run_folder_replaces_the_whole_folder(tmp_path):
    folder = tmp_path / "run"
    with outputs.run_folder(folder) as temporary:
        assert temporary.parent == tmp_path and temporary.name.startswith(".run.uvms-tmp-")
        outputs.write_json(temporary / "metrics.json", {"run": 1})
        (temporary / "old_figure.png").write_bytes(b"png")
    umask = os.umask(0)
    os.umask(umask)
    assert folder.stat().st_mode & 0o777 == 0o777 & ~umask  # not mkdtemp's 0700
    assert json.loads((folder / outputs.MANIFEST).read_text())["entries"] == ["metrics.json", "old_figure.png"]
    with outputs.run_folder(folder) as temporary:
        outputs.write_json(temporary / "metrics.json", {"run": 2})
    assert sorted(p.name for p in folder.iterdir()) == [outputs.MANIFEST, "metrics.json"]  # none of the first run
    assert json.loads((folder / "metrics.json").read_text()) == {"run": 2}
    assert json.loads((folder / outputs.MANIFEST).read_text())["entries"] == ["metrics.json"]
    assert sorted(p.name for p in tmp_path.iterdir()) == [".run.uvms-lock", "run"]


@pytest.mark.parametrize("exchange", [True, False], ids=["renameat2", "two-renames"])
def test_an_exception_inside_leaves_the_old_folder_untouched(tmp_path, monkeypatch, exchange):
    if not exchange:  # the fallback of other systems
        monkeypatch.setattr(outputs, "_exchange", lambda first, second: False)
    folder = tmp_path / "run"
    with outputs.run_folder(folder) as temporary:
        outputs.write_json(temporary / "metrics.json", {"run": 1})
    for error in (RuntimeError("writer died"), KeyboardInterrupt()):
        with pytest.raises(type(error)) as raised, outputs.run_folder(folder) as temporary:
            outputs.write_json(temporary / "metrics.json", {"run": 2})
            (temporary / "half.csv").write_text("t,")
            raise error
        assert sorted(snapshot(folder)) == [outputs.MANIFEST, "metrics.json"] and not temporaries(folder)
        assert (folder / "metrics.json").read_bytes() == b'{\n  "run": 1\n}\n'
    assert raised.value.__notes__ == [f"{folder} keeps the previous complete run"]
    with outputs.run_folder(folder) as temporary:  # and the next run goes through
        outputs.write_json(temporary / "metrics.json", {"run": 3})
    assert json.loads((folder / "metrics.json").read_text()) == {"run": 3} and not temporaries(folder)


def test_an_exception_inside_a_scenario_run_leaves_the_old_folder_untouched(tmp_path, monkeypatch):
    folder = tmp_path / "run"
    run_scenario(SANTOS, out=folder, progress=False)
    before = snapshot(folder)

    def broken(figure, path, dpi=110):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(outputs, "save_figure", broken)
    with pytest.raises(DiskFullError, match=f"no space left on the device holding '{tmp_path}' .*{folder} keeps the "
                                            f"previous complete run"):
        run_scenario(SANTOS, out=folder, overrides=["solver.gain=2"], progress=False)
    assert snapshot(folder) == before and not temporaries(folder)


def test_a_second_writer_is_refused_at_once(tmp_path):
    folder = tmp_path / "run"
    with outputs.run_folder(folder):
        started = time.monotonic()
        with pytest.raises(RunFolderBusy, match=f"another uvms process is writing {folder}; wait for it or choose"):
            with outputs.run_folder(folder):
                pass
        assert time.monotonic() - started < 1.0
    with outputs.run_folder(folder):  # released
        pass


def test_stale_temporaries_are_removed_by_the_next_run_only(tmp_path):
    folder = tmp_path / "run"
    stale = [tmp_path / ".run.uvms-tmp-abcd1234", tmp_path / ".run.uvms-tmp-old-0123abcd"]
    for path in stale:
        (path / "sub").mkdir(parents=True)
    others = [tmp_path / ".run2.uvms-tmp-abcd1234", tmp_path / "run.uvms-tmp-abcd1234", tmp_path / ".run.uvms-tmp-x"]
    for path in others:  # other folders' temporaries and names that only look alike are not touched
        path.mkdir()
    with outputs.run_folder(folder) as temporary:
        outputs.write_json(temporary / "metrics.json", {})
    assert not any(path.exists() for path in stale) and all(path.exists() for path in others)


def test_folders_that_uvms_did_not_write_are_never_replaced(tmp_path):
    mine = tmp_path / "thesis"
    mine.mkdir()
    (mine / "chapter1.tex").write_text("precious")
    with pytest.raises(RunFolderError, match="not written by uvms .*choose a new or empty folder"):
        with outputs.run_folder(mine):
            pass
    (tmp_path / "file").write_text("x")
    with pytest.raises(RunFolderError, match="is a file"):
        with outputs.run_folder(tmp_path / "file"):
            pass
    with pytest.raises(RunFolderError, match="file system root"):
        with outputs.run_folder("/"):
            pass
    assert (mine / "chapter1.tex").read_text() == "precious"
    empty = tmp_path / "empty"
    empty.mkdir()
    with outputs.run_folder(empty) as temporary:  # an empty folder is fine
        (temporary / "a.txt").write_text("a")
    assert (empty / "a.txt").exists()
    assert issubclass(RunFolderError, UVMSError)


def test_a_symbolic_link_to_a_run_folder_keeps_pointing_to_the_new_run(tmp_path):
    target = tmp_path / "data" / "run"
    with outputs.run_folder(target) as temporary:
        outputs.write_json(temporary / "metrics.json", {"run": 1})
    link = tmp_path / "link"
    link.symlink_to(target)
    with outputs.run_folder(link) as temporary:
        outputs.write_json(temporary / "metrics.json", {"run": 2})
    assert link.is_symlink() and json.loads((link / "metrics.json").read_text()) == {"run": 2}


def test_run_reports_the_final_paths(tmp_path):
    result = run_scenario(SANTOS, out=tmp_path / "run", progress=False, overrides=["outputs.figures=false"])
    assert [path.name for path in result.files] == ["trajectory.csv", "trajectory.npz", "metrics.json"]
    assert all(path.parent == tmp_path / "run" and path.is_file() for path in result.files)


# ------------------------------------------------------------------ killed, concurrent, interrupted
def test_a_killed_run_leaves_exactly_the_previous_run_and_the_next_run_cleans_up(previous_run):
    folder, before = previous_run
    child = slow_child(0.5, "run", str(SANTOS), "--out", str(folder), "--quiet", "--set", "solver.gain=2")
    try:
        wait_for(writing(folder, "desired_motion.png"), process=child)  # trajectory written, figures under way
    finally:
        child.send_signal(signal.SIGKILL)
        child.communicate()
    assert snapshot(folder) == before  # the file set and every byte, metrics.json included
    assert len(temporaries(folder)) == 1  # the killed run's, with its new trajectory.* in it
    done = subprocess.run(uvms_command("run", str(SANTOS), "--out", str(folder), "--quiet", "--set",
                                       "outputs.figures=false"), capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert not temporaries(folder)
    assert {path.name for path in folder.iterdir()} == {"metrics.json", "trajectory.csv", "trajectory.npz",
                                                        outputs.MANIFEST}


def test_a_second_concurrent_run_is_refused_and_the_first_completes(tmp_path):
    folder = tmp_path / "out" / "run"
    first = slow_child(0.3, "run", str(SANTOS), "--out", str(folder), "--quiet")
    try:
        wait_for(lambda: temporaries(folder), process=first)  # the first run holds the folder
        second = subprocess.run(uvms_command("run", str(SANTOS), "--out", str(folder), "--quiet", "--set",
                                             "solver.gain=2"), capture_output=True, text=True, timeout=300)
        assert first.poll() is None, "the first run ended before the second one was tried"
    finally:
        out, err = first.communicate(timeout=300)
    assert second.returncode == 2 and second.stdout == ""
    assert second.stderr.splitlines() == [f"uvms: error: another uvms process is writing {folder}; wait for it or "
                                          f"choose another --out"]
    assert first.returncode == 0, err
    assert {path.name for path in folder.iterdir()} == RUN_FILES and not temporaries(folder)
    metrics = json.loads((folder / "metrics.json").read_text())
    assert metrics["steps"] == 100 and metrics["max_position_error"] < 0.07  # the first run's, gain 1


@pytest.mark.parametrize("previous", [True, False], ids=["over-a-previous-run", "new-folder"])
def test_ctrl_c_keeps_the_previous_run_and_exits_130(tmp_path, previous):
    folder = tmp_path / "out" / "run"
    before = None
    if previous:
        run_scenario(SANTOS, out=folder, progress=False)
        before = snapshot(folder)
    child = slow_child(0.5, "run", str(SANTOS), "--out", str(folder), "--quiet", "--set", "solver.gain=2")
    wait_for(writing(folder, "desired_motion.png"), process=child)
    child.send_signal(signal.SIGINT)
    out, err = child.communicate(timeout=60)
    assert child.returncode == 130
    expected = f"{folder} keeps the previous complete run" if previous else f"nothing was written to {folder}"
    assert err.splitlines() == [f"uvms: interrupted; {expected}"]
    assert not temporaries(folder)
    if previous:
        assert snapshot(folder) == before
    else:
        assert not folder.exists()


def tree(folder: Path) -> dict[str, tuple[int, int]]:
    """Every path below ``folder`` (hidden ones included) with its size and modification time."""
    found = {}
    for root, dirs, files in os.walk(folder):
        for name in dirs + files:
            path = Path(root) / name
            with_stat = path.lstat()
            found[str(path.relative_to(folder))] = (with_stat.st_size, with_stat.st_mtime_ns)
    return found


def descendants(pid: int) -> set[int]:
    """The processes below ``pid`` (psutil if installed, else /proc)."""
    try:
        import psutil
    except ImportError:
        psutil = None
    if psutil is not None:
        return {child.pid for child in psutil.Process(pid).children(recursive=True)}
    parents = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                parents[int(entry.name)] = int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
    found, frontier = set(), {pid}
    while frontier:
        frontier = {child for child, parent in parents.items() if parent in frontier} - found
        found |= frontier
    return found


def alive(pid: int) -> bool:
    """True if ``pid`` runs (a zombie, exited but not yet reaped by its parent, does not count)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state not in ("Z", "X")


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc to follow the worker processes")
def test_ctrl_c_stops_a_sweep_and_its_workers(tmp_path):
    folder = tmp_path / "out" / "sweep"
    workers: set[int] = set()

    def two_workers(child) -> None:
        workers.update(descendants(child.pid))
        assert len(workers) >= 2

    child, err = signal_a_running_sweep(folder, "solver.gain=[1.0, 2.0, 3.0, 4.0]", signal.SIGINT, two_workers)
    assert child.returncode == 130
    assert err.splitlines() == [f"uvms: interrupted; nothing was written to {folder}"]
    deadline = time.monotonic() + 10
    while any(alive(pid) for pid in workers) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not [pid for pid in workers if alive(pid)]  # no worker goes on running
    time.sleep(1.0)
    first = tree(folder.parent)
    time.sleep(2.0)
    assert tree(folder.parent) == first  # and nothing writes any more
    assert sorted(first) == [".sweep.uvms-lock"]  # no sweep folder, no temporary left


def test_ctrl_c_message_without_a_folder(monkeypatch, capsys):
    def interrupted(options):
        raise KeyboardInterrupt

    monkeypatch.setattr("uvms.cli.command_info", interrupted)  # build_parser looks the handler up at call time
    assert main(["info", "hoang2011"]) == 130
    assert capsys.readouterr().err == "uvms: interrupted\n"
