"""Monte Carlo studies of a scenario: sampled overrides, one run per trial, resumable, on joblib or Dask.

``study(scenario, ["model.args.l1=normal(0.4, 0.02)", ...], n=64, seed=1)`` draws n trials
(:mod:`uvms.scenario.studies.distributions`), checks every trial's keys and values before any runs, and runs trial k as
:func:`uvms.scenario.run_scenario` with its values as ``--set`` overrides into ``DIR/trials/trial_k`` (no
figures), through :mod:`uvms.scenario.studies.parallel`. Each finished trial writes its row atomically to
``DIR/trials/trial_k.json``; ``study.csv``, ``summary.json`` and the figures (:mod:`uvms.viz.study`) are written
from the rows at the end.

Resume: ``DIR/study.json`` holds the study's spec (scenario and model files by content hash, samples, n, seed,
method, overrides). Running the same spec into ``DIR`` again skips the trials whose row is there and runs the
rest; a different spec is refused (a study folder never mixes two studies). Each row found is checked against
the trial it claims and a symbolic link in the folder is refused (:mod:`uvms.scenario.studies.folder`). A trial that
raises is a row with its error text; a trial whose worker dies is run again alone, and if it kills that worker too it is
a row "killed". The table does not depend on the backend, the number of jobs or the interruptions.
"""

from __future__ import annotations

import csv
import hashlib
import io
import math
import os
import secrets
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ...errors import StudyError
from ...io import outputs
from ..resources import resolve_scenario_path
from ..schema import read_scenario, read_toml, scenario_from_raw
from ..spec import ScenarioSpec
from .distributions import METHODS, Distribution, parse_samples, sample_table
from .folder import (
    METRICS,
    TRIALS,
    finished_rows,
    killed_row,
    open_study_folder,
    started_by,
    trial_name,
)
from .parallel import check_backend, exit_if_orphaned, run_tasks
from .parallel import use_thread_lock_for_progress_bars as thread_lock
from .sensitivity import summarize
from .sweep import csv_cell, toml_literal

MAX_TRIALS = 100_000
#: exceptions (by name) by which joblib reports a dead worker: loky's, concurrent.futures', Dask's
DEAD_WORKER = ("TerminatedWorkerError", "BrokenProcessPool", "KilledWorker")


@dataclass
class StudyResult:
    """A finished study: one row per trial, the summary (:func:`uvms.scenario.studies.sensitivity.summarize`), files."""

    keys: list[str]
    metrics: list[str]
    rows: list[dict]
    summary: dict
    files: list[Path] = field(default_factory=list)
    resumed: int = 0  # trials found finished in the folder

    @property
    def columns(self) -> list[str]:
        """Column names of ``study.csv``, in order."""
        return ["trial", "seed", *self.keys, *self.metrics, "pass", "error"]

    def csv(self) -> str:
        """The table as CSV text (full precision, text that would start a formula neutralised)."""
        buffer = io.StringIO()
        writer = csv.writer(buffer, lineterminator="\n")
        writer.writerow([csv_cell(c) for c in self.columns])
        for row in self.rows:
            writer.writerow([csv_cell(row.get(c, math.nan)) for c in self.columns])
        return buffer.getvalue()


def study_spec(scenario: Path, samples: Sequence[tuple[str, Distribution]], n: int, seed: int, method: str,
               overrides: Sequence[str], inputs: Sequence[Path]) -> dict:
    """What makes a study: two runs with equal specs compute the same trials (the JSON of ``study.json``)."""
    digests = {}
    for path in inputs:
        if path.is_file():
            digests[str(path)] = hashlib.sha256(path.read_bytes()).hexdigest()
    return {"scenario": str(scenario), "inputs_sha256": digests, "n": n, "seed": seed, "method": method,
            "samples": [f"{key}={distribution.text()}" for key, distribution in samples],
            "overrides": list(overrides)}


def assignments_of(spec: ScenarioSpec, keys: Sequence[str], values: Sequence[Any]) -> list[str]:
    """The ``--set`` strings of one trial; elements ``KEY[i]`` of a list key are merged into the scenario's list."""
    lists: dict[str, list] = {}
    plain = []
    for key, value in zip(keys, values):
        if "[" not in key:
            plain.append(f"{key}={toml_literal(value)}")
            continue
        base, index = key[:-1].split("[")
        section, name = base.split(".", 1)
        current = lists.setdefault(base, list(getattr(getattr(spec, section, None), name, None) or []))
        if int(index) >= len(current):
            raise StudyError(f"--samples {key}: {base} = {current} has no element {index} (a list of {len(current)}); "
                             f"give the whole list in the scenario or sample {base}[0..{max(len(current) - 1, 0)}]")
        current[int(index)] = value
    return plain + [f"{base}=[{', '.join(toml_literal(v) for v in items)}]" for base, items in lists.items()]


def check_trials(scenario: Path, keys: Sequence[str], table: Sequence[Sequence[Any]],
                 overrides: Sequence[str]) -> list[list[str]]:
    """Every trial's overrides, each checked against the schema in this process before any trial runs."""
    raw = read_toml(scenario)
    base = scenario_from_raw(raw, scenario, overrides)
    trials = []
    for values in table:
        assignments = [*overrides, *assignments_of(base, keys, values)]
        scenario_from_raw(raw, scenario, assignments)
        trials.append(assignments)
    if any(key.startswith("model.args.") for key in keys) and trials:  # xacro args: the model declares them
        from ..record import scenario_model

        scenario_model(read_scenario(scenario, trials[0]).model)
    return trials


def run_trial(scenario: str, index: int, seed: int, values: list, assignments: list[str], folder: str,
              token: str) -> dict:
    """Run one trial (in a worker) and write its row to ``folder/trial_k.json``; an exception is the row's error."""
    from ..runs import run_scenario

    thread_lock()
    name = trial_name(index)
    outputs.write_text(Path(folder) / f"{name}.started", token)  # which trials a dead worker was running
    row: dict[str, Any] = {"trial": index, "seed": seed, "values": values, "error": "", "pass": False}
    try:
        metrics = run_scenario(scenario, out=Path(folder) / name, overrides=[*assignments, "outputs.figures=false"],
                               progress=False, lock=False).metrics
        row.update({key: float(metrics[key]) for key in METRICS if key in metrics})
        row["pass"], row["wall_time"] = bool(metrics["verdict"]["ok"]), float(metrics["wall_time"])
    except Exception as exc:  # noqa: BLE001 - one failed trial must not stop the study; it is reported
        message = " ".join(str(exc).split())
        row["error"] = f"{type(exc).__name__}: {message}" if message else type(exc).__name__
    # no row once the study's process is gone (its lock with it): checked last, just before the row appears
    outputs.write_json(Path(folder) / f"{name}.json", row, before_replace=exit_if_orphaned)
    (Path(folder) / f"{name}.started").unlink(missing_ok=True)
    return row


def study(
    scenario: str | os.PathLike,
    samples: Sequence[str] | None = None,
    *,
    n: int | None = None,
    seed: int | None = None,
    method: str | None = None,
    jobs: int = 1,
    backend: str = "loky",
    scheduler: str | None = None,
    out: str | os.PathLike | None = None,
    progress: bool | None = None,
    overrides: Sequence[str] = (),
    insecure_scheduler: bool = False,
) -> StudyResult:
    """Run a Monte Carlo study of a scenario; write ``study.csv``, ``summary.json`` and figures into ``out``.

    Args:
        scenario: the TOML file, or the name of a shipped scenario.
        samples: ``KEY=DIST`` strings (:mod:`uvms.scenario.studies.distributions`); None: ``[study] samples``.
        n: trials (None: ``[study] n``); seed: the study's seed (None: ``[study] seed``); method: ``"random"``,
            ``"lhs"`` or ``"sobol"`` (None: ``[study] method``).
        jobs, backend, scheduler: as for :func:`uvms.scenario.studies.sweep.sweep`
            (:mod:`uvms.scenario.studies.parallel`).
        out: the study folder (default ``out/<scenario name>_study``); resumed if it holds the same study.
        progress: progress bar (None: on a terminal only).
        overrides: ``SECTION.KEY=VALUE`` strings applied to every trial before its sampled values (after
            ``[study] set``).
        insecure_scheduler: accept a ``scheduler`` that is not ``tls://`` (as for
            :func:`uvms.scenario.studies.sweep.sweep`).

    Raises:
        StudyError: bad samples, n, method, backend or jobs, or ``out`` holds another study or other files;
            ScenarioError: a key or value the scenario rejects, found before any trial runs.
    """
    scenario = resolve_scenario_path(scenario).resolve()
    given = read_scenario(scenario, overrides).study
    overrides = [*given.set, *overrides]
    table = read_scenario(scenario, overrides)
    samples = parse_samples(list(given.samples) if samples is None else samples)
    n, seed = given.n if n is None else n, given.seed if seed is None else seed
    method = given.method if method is None else method
    if not isinstance(n, int) or isinstance(n, bool) or not 1 <= n <= MAX_TRIALS:
        raise StudyError(f"a study has 1 to {MAX_TRIALS:,} trials (-n N or [study] n), got {n!r}")
    if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
        raise StudyError(f"the seed of a study is an integer >= 0, got {seed!r}")
    if method not in METHODS:
        raise StudyError(f"study method {method!r} is not valid; valid: {', '.join(METHODS)}")
    check_backend(backend, scheduler, jobs, StudyError, insecure_scheduler)
    keys = [key for key, _ in samples]
    seeds, values = sample_table(samples, n, seed, method)
    trials = check_trials(scenario, keys, values, overrides)
    from ..runs import run_inputs

    inputs = run_inputs(scenario, [table.model.path], table.named_files())
    spec = study_spec(scenario, samples, n, seed, method, overrides, inputs)
    folder = Path(out) if out is not None else Path("out") / f"{table.name}_study"
    release = open_study_folder(folder, spec)
    try:
        rows, resumed = run_study(scenario, seeds, values, trials, folder / TRIALS, jobs=jobs, backend=backend,
                                  scheduler=scheduler, progress=progress, insecure_scheduler=insecure_scheduler)
        return finish(folder, keys, rows, resumed, spec, table.name)
    finally:
        release()


def run_study(scenario: Path, seeds: Sequence[int], values: Sequence[list], trials: Sequence[list[str]],
              folder: Path, **executor: Any) -> tuple[list[dict], int]:
    """Run the trials without a row in ``folder``; a dead worker's trials again, each alone; the rows by trial."""
    rows = finished_rows(folder, seeds, values, warn=True)
    resumed = len(rows)
    pending = [k for k in range(len(seeds)) if k not in rows]
    suspects: list[int] = []
    crashed = False  # after a dead worker, every trial runs in a worker process (never in this one)
    while pending or suspects:
        batch, alone = (suspects[:1], True) if suspects else (pending, False)
        token = secrets.token_hex(8)
        tasks = [(str(scenario), k, seeds[k], values[k], trials[k], str(folder), token) for k in batch]
        try:  # a suspect alone, in a worker process: if it kills that one too, it killed the first
            for row in run_tasks(run_trial, tasks, error=StudyError, desc="study", in_workers=crashed, **executor):
                rows[row["trial"]] = row
        except Exception as exc:  # a dead worker; anything else is raised again
            if type(exc).__name__ not in DEAD_WORKER:
                raise
            crashed = True
            rows.update(finished_rows(folder, seeds, values))
            if alone:
                rows[batch[0]] = killed_row(folder, batch[0], seeds[batch[0]], values[batch[0]], exc)
            else:
                suspects = [k for k in batch if k not in rows and started_by(folder, k, token)]
        if alone:
            suspects = suspects[1:]
        pending = [k for k in pending if k not in rows and k not in suspects]
    return [rows[k] for k in range(len(seeds))], resumed


def finish(folder: Path, keys: list[str], rows: list[dict], resumed: int, spec: dict, name: str) -> StudyResult:
    """The table, summary.json and the figures from the rows."""
    from ...viz.study import save_study_figures

    metrics = [m for m in METRICS if any(m in row for row in rows)]
    table = [{"trial": row["trial"], "seed": row["seed"], **dict(zip(keys, row["values"])),
              **{m: row.get(m, math.nan) for m in metrics}, "pass": row["pass"], "error": row["error"]}
             for row in rows]
    summary = summarize(table, keys, metrics)
    summary.update(spec=spec, wall_time=sum(row.get("wall_time", 0.0) for row in rows))
    result = StudyResult(keys=keys, metrics=metrics, rows=table, summary=summary, resumed=resumed)
    outputs.write_text(folder / "study.csv", result.csv())
    outputs.write_json(folder / "summary.json", summary)
    figures = save_study_figures(table, keys, metrics, summary, folder, title=name)
    result.files = [folder / "study.csv", folder / "summary.json", *figures]
    return result


__all__ = ["METRICS", "StudyError", "StudyResult", "study"]
