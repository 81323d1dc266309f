"""`uvms study` (uvms.scenario.studies.study): one table on any backend and worker count, resume after SIGKILL, failed
and killed trials, sensitivity, refused folders and bad input before any trial."""

from __future__ import annotations

import contextlib
import csv
import json
import math
import os
import shutil
import signal
import subprocess
import time
from pathlib import Path

import pytest

from uvms.errors import StudyError, StudyResumeWarning, UVMSError
from uvms.scenario import ScenarioError
from uvms.scenario.studies import study as study_module
from uvms.scenario.studies.study import study

from conftest import SCENARIOS, uvms_command, wait_for

SCENARIO = SCENARIOS / "hoang2011_w1.toml"
SHORT = ["trajectory.duration=10", "trajectory.accel_time=2"]  # 500 steps
# max_position_error depends on l1 only (about 3.65e-10 m, falling with l1); the tolerance sets pass/fail alone
SAMPLES = ["model.args.l1=uniform(0.35, 0.5)", "outputs.position_tolerance=loguniform(1e-10, 1e-9)"]
N, SEED = 10, 7


def trials_of(folder) -> list[str]:
    return sorted(path.name for path in (folder / "trials").glob("trial_*.json"))


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    return study(SCENARIO, SAMPLES, n=N, seed=SEED, out=tmp_path_factory.mktemp("study1") / "s", progress=False,
                 overrides=SHORT)


def test_the_table_holds_one_row_per_trial_with_its_seed_values_metrics_and_verdict(reference):
    folder = reference.files[0].parent
    assert reference.columns[:4] == ["trial", "seed", "model.args.l1", "outputs.position_tolerance"]
    assert reference.columns[-2:] == ["pass", "error"] and "max_vehicle_tilt" not in reference.columns  # planar
    rows = reference.rows
    assert [row["trial"] for row in rows] == list(range(N)) and not any(row["error"] for row in rows)
    assert all(0.35 <= row["model.args.l1"] <= 0.5 and 1e-10 <= row["outputs.position_tolerance"] <= 1e-9
               for row in rows)
    for row in rows:  # the verdict of each run: its error against its own sampled tolerance
        assert row["pass"] == (row["max_position_error"] <= row["outputs.position_tolerance"])
        assert 3e-10 < row["max_position_error"] < 4e-10
    passed = sum(row["pass"] for row in rows)
    assert 0 < passed < N and reference.summary["pass_rate"]["passed"] == passed
    table = list(csv.DictReader((folder / "study.csv").read_text().splitlines()))
    assert [float(row["max_position_error"]) for row in table] == [row["max_position_error"] for row in rows]
    assert [int(row["seed"]) for row in table] == [row["seed"] for row in rows]
    summary = json.loads((folder / "summary.json").read_text())
    assert summary["pass_rate"]["rate"] == passed / N and summary["pass_rate"]["ci_method"] == "wilson"
    metric = sorted(row["max_position_error"] for row in rows)
    assert summary["metrics"]["max_position_error"]["max"] == metric[-1]
    assert [path.name for path in reference.files] == ["study.csv", "summary.json", "study_histograms.png",
                                                       "study_scatter.png", "study_sensitivity.png"]
    assert (folder / "trials" / "trial_00009" / "metrics.json").is_file()
    assert not list((folder / "trials").glob("*.started"))


def test_sensitivity_ranks_the_one_key_the_metric_depends_on_first(reference):
    ranking = reference.summary["sensitivity"]
    first = ranking["max_position_error"][0]
    assert first["key"] == "model.args.l1" and first["rho"] < -0.95 and first["p_value"] < 1e-3
    assert first["eta2"] > 0.8 > 2 / 9 == pytest.approx(reference.summary["eta2_noise_floor"])  # 3 bins of 10
    assert ranking["pass"][0]["key"] == "outputs.position_tolerance" and ranking["pass"][0]["rho"] > 0.6


def same_table(result, reference) -> bool:
    """Trials, seeds, sampled values, verdicts and errors equal; metrics equal to 1e-6 relative: this scenario's
    errors (3.7e-10 m) are rounding, and the parent (jobs=1) and the workers round alike only to about 1e-16 m."""
    assert len(result.rows) == len(reference.rows)
    for row, expected in zip(result.rows, reference.rows):
        assert {k: v for k, v in row.items() if k not in result.metrics} == \
            {k: v for k, v in expected.items() if k not in reference.metrics}
        assert [row[m] for m in result.metrics] == pytest.approx([expected[m] for m in reference.metrics], rel=1e-6)
    return True


def test_two_jobs_give_the_same_table(reference, tmp_path):
    result = study(SCENARIO, SAMPLES, n=N, seed=SEED, jobs=2, out=tmp_path / "s", progress=False, overrides=SHORT)
    assert same_table(result, reference)


def test_a_local_dask_cluster_gives_the_same_table(reference, tmp_path):
    pytest.importorskip("dask.distributed")
    result = study(SCENARIO, SAMPLES, n=N, seed=SEED, jobs=2, backend="dask", out=tmp_path / "s", progress=False,
                   overrides=SHORT)
    assert same_table(result, reference)


def descendants(pid: int) -> set[int]:
    """The processes whose parent chain leads to ``pid`` (from /proc: psutil is not required)."""
    parents = {}
    for entry in Path("/proc").iterdir():
        with contextlib.suppress(OSError, IndexError, ValueError):
            parents[int(entry.name)] = int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
    found, frontier = set(), {pid}
    while frontier:
        frontier = {child for child, parent in parents.items() if parent in frontier} - found
        found |= frontier
    return found


def running(pid: int) -> bool:
    """Whether ``pid`` runs (a zombie, which no one may reap in a container, does not)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] not in ("Z", "X")
    except OSError:
        return False


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads the process tree from /proc")
def test_resume_after_a_sigkill_of_the_study_whose_workers_stop_with_it(reference, tmp_path):
    folder = tmp_path / "s"
    command = uvms_command("study", str(SCENARIO), *[f"--samples={s}" for s in SAMPLES], "-n", str(N),
                           "--seed", str(SEED), *[f"--set={s}" for s in SHORT], "--jobs", "2", "--out", str(folder),
                           "--quiet")
    errors = tmp_path / "stderr.txt"
    with errors.open("w") as stderr:  # not a pipe: the old code's surviving workers held it open
        child = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=stderr, start_new_session=True)
    try:
        def some_rows() -> bool:
            assert child.poll() is None, errors.read_text()
            return folder.is_dir() and len(trials_of(folder)) >= 2

        wait_for(some_rows)
        workers = descendants(child.pid)  # 2 loky workers and resource trackers
        os.kill(child.pid, signal.SIGKILL)  # the study alone, as `kill -9 PID` or the OOM killer would
        child.wait()
        done = trials_of(folder)
        assert len(workers) >= 2 and 2 <= len(done) < N
        started = time.monotonic()
        wait_for(lambda: not any(running(pid) for pid in workers), timeout=5)
        assert time.monotonic() - started < 2  # PARENT_POLL is 0.1 s
        time.sleep(0.3)
        assert trials_of(folder) == done  # none written without the study (and its lock)
    finally:
        with contextlib.suppress(OSError):
            os.killpg(child.pid, signal.SIGKILL)  # whatever outlived it (the old code's workers)
    assert not (folder / "study.csv").exists()
    result = study(SCENARIO, SAMPLES, n=N, seed=SEED, out=folder, progress=False, overrides=SHORT)
    assert result.resumed >= len(done)  # those were not run again
    assert same_table(result, reference)  # none lost, none twice
    assert trials_of(folder) == [f"trial_{k:05d}.json" for k in range(N)]
    assert not list((folder / "trials").glob(".trial_*"))  # the killed trials' unfinished run folders are gone


def test_another_study_or_other_files_are_refused(reference, tmp_path):
    folder = reference.files[0].parent
    with pytest.raises(StudyError, match="holds another study \\(it differs in seed\\)"):
        study(SCENARIO, SAMPLES, n=N, seed=SEED + 1, out=folder, progress=False, overrides=SHORT)
    with pytest.raises(StudyError, match="differs in n, samples"):
        study(SCENARIO, SAMPLES[:1], n=N + 1, seed=SEED, out=folder, progress=False, overrides=SHORT)
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("keep")
    with pytest.raises(StudyError, match="is not a study folder"):
        study(SCENARIO, SAMPLES, n=2, seed=SEED, out=tmp_path / "mine", progress=False, overrides=SHORT)
    assert sorted(p.name for p in (tmp_path / "mine").iterdir()) == ["notes.txt"]


def test_a_failed_trial_is_recorded_and_the_study_goes_on(tmp_path):
    result = study(SCENARIO, ["model.args.vehicle_mass=choice([120.0, -5.0])"], n=4, seed=1, out=tmp_path / "s",
                   progress=False, overrides=SHORT)
    bad = [row for row in result.rows if row["model.args.vehicle_mass"] < 0]
    good = [row for row in result.rows if row["model.args.vehicle_mass"] > 0]
    assert bad and good and len(bad) + len(good) == 4
    assert all("ModelCheckError" in row["error"] and not row["pass"] and math.isnan(row["max_position_error"])
               for row in bad)
    assert all(not row["error"] and math.isfinite(row["max_position_error"]) for row in good)
    assert result.summary["failed_trials"] == [row["trial"] for row in bad]
    assert result.summary["pass_rate"]["trials"] == 4


def crashing_trial(scenario, index, *arguments):
    """Trial 1 kills its worker process when its run starts (after its marker); the others run as usual."""
    from uvms.scenario import runs
    from uvms.scenario.studies import study as module  # in a worker: not monkeypatched

    if index == 1:  # in this worker only, which dies with it
        runs.run_scenario = lambda *args, **kwargs: os._exit(3)
    return module.run_trial(scenario, index, *arguments)


def test_a_trial_that_kills_its_worker_is_recorded_and_the_others_run(tmp_path, monkeypatch):
    monkeypatch.setattr(study_module, "run_trial", crashing_trial)
    result = study(SCENARIO, SAMPLES, n=4, seed=SEED, jobs=2, out=tmp_path / "s", progress=False, overrides=SHORT)
    killed = [row for row in result.rows if row["error"]]
    assert [row["trial"] for row in killed] == [1] and killed[0]["error"].startswith("killed: the worker")
    assert all(math.isfinite(row["max_position_error"]) for row in result.rows if row["trial"] != 1)


def test_bad_samples_keys_and_options_fail_before_any_trial(tmp_path):
    out = tmp_path / "s"
    cases = [
        (StudyError, "valid forms", dict(samples=["solver.gain=gauss(1, 2)"])),
        (ScenarioError, "valid in \\[solver\\]", dict(samples=["solver.gian=uniform(1, 2)"])),
        (UVMSError, "unknown xacro arg.*l1, l2, l3", dict(samples=["model.args.l9=uniform(1, 2)"])),
        (StudyError, "has no element 3", dict(samples=["trajectory.start[3]=uniform(1, 2)"])),
        (StudyError, "1 to 100,000 trials", dict(samples=SAMPLES, n=0)),
        (StudyError, "method 'grid'", dict(samples=SAMPLES, method="grid")),
        (StudyError, "backend 'ray'", dict(samples=SAMPLES, backend="ray")),
        (StudyError, "at least one --samples", dict(samples=None)),  # the scenario has no [study] table
    ]
    for error, words, options in cases:
        with pytest.raises(error, match=words):
            study(SCENARIO, n=options.pop("n", 3), out=out, progress=False, **options)
        assert not out.exists()


def test_resume_refuses_a_planted_link_and_runs_edited_rows_again(tmp_path):
    folder, trials = tmp_path / "s", tmp_path / "s" / "trials"
    options = {"n": 5, "seed": SEED, "out": folder, "progress": False,
               "overrides": ["trajectory.duration=2", "trajectory.accel_time=0.5"]}
    first = study(SCENARIO, SAMPLES, **options)
    user = tmp_path / "user" / "important_run"  # a run folder of the user's (here a copy of a trial's)
    shutil.copytree(trials / "trial_00002", user)
    (user / "metrics.json").write_text((user / "metrics.json").read_text().replace("{", '{"mine": 1,', 1))
    shutil.rmtree(trials / "trial_00002")
    (trials / "trial_00002.json").unlink()
    (trials / "trial_00002").symlink_to(Path("..", "..", "user", "important_run"))
    with pytest.raises(StudyError, match=r"trial_00002' in the study folder .* is a symbolic link, which uvms never"):
        study(SCENARIO, SAMPLES, **options)
    assert json.loads((user / "metrics.json").read_text())["mine"] == 1  # not replaced
    (trials / "trial_00002").unlink()

    def edit(index: int, change) -> None:
        path = trials / f"trial_{index:05d}.json"
        row = json.loads(path.read_text())
        change(row)
        path.write_text(json.dumps(row))

    edit(0, lambda row: row.update(max_position_error=123.0))  # 123 m, by hand
    edit(1, lambda row: row.update(trial=0))  # a second trial 0
    edit(3, lambda row: row.pop("pass"))
    edit(4, lambda row: row.update(wall_time="x"))
    with pytest.warns(StudyResumeWarning) as caught:
        result = study(SCENARIO, SAMPLES, **options)
    message = str(caught[0].message)
    assert message.startswith("4 row(s) in ") and "are not the trials they claim and are run again" in message
    for words in ("trial 0: its metrics or verdict differ from those of trial_00000/metrics.json",
                  "trial 1: it claims trial 0", "trial 3: no boolean pass", "trial 4: a metric or wall_time"):
        assert words in message
    assert result.resumed == 0 and [row["trial"] for row in result.rows] == list(range(5))
    assert same_table(result, first)  # as if never touched: 3.7e-10 m errors, the same pass rate
    assert result.summary["pass_rate"]["passed"] == first.summary["pass_rate"]["passed"]
