"""Tuning scenario keys (gains, bandwidths...) with Optuna: one run, or a small study, per trial.

``tune(scenario, ["solver.gain=0.5:4:log"], objective="max_position_error", trials=30)`` asks Optuna's TPE
sampler (seeded: the same seed gives the same history) for values of the parameters, runs the scenario with
them (``--set`` overrides) and minimises the metric; with ``samples`` (``KEY=DIST`` as for
:func:`uvms.scenario.studies.study.study`), every trial is a small study over the sampled disturbances, and the
objective is the mean of the metric over its trials, or ``pass_rate`` (maximised): robust tuning. The study
trials run on loky or Dask (:mod:`uvms.scenario.studies.parallel`); the Optuna trials one after the other.

The output folder (replaced whole, :func:`uvms.io.outputs.run_folder`) holds ``tune.csv`` (one row per trial),
``best.json`` (the best parameters, value, and the ``--set`` list), ``best.toml`` (the same as a TOML fragment
to paste into the scenario), ``tune_history.png`` and ``trials/trial_k`` (the run or study of trial k).
Optuna is an optional extra: ``pip install uvms[tune]``.
"""

from __future__ import annotations

import csv
import io
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ...errors import StudyError
from ...io import outputs
from ..resources import resolve_scenario_path
from ..schema import read_scenario
from .distributions import KEY_PATTERN, parse_samples
from .parallel import check_backend
from .study import METRICS, study
from .sweep import csv_cell, toml_literal

OBJECTIVES = (*METRICS, "pass_rate")
MAX_TUNE_TRIALS = 10_000


@dataclass(frozen=True)
class Parameter:
    """A tuned key: its range [low, high], sampled in log if ``log``."""

    key: str
    low: float
    high: float
    log: bool = False


def parse_parameter(text: str) -> Parameter:
    """``KEY=LOW:HIGH`` or ``KEY=LOW:HIGH:log``.

    Raises:
        StudyError: not of that form, LOW >= HIGH, a bound not finite, log with LOW <= 0.
    """
    key, sep, spec = text.partition("=")
    key, parts = key.strip(), spec.strip().split(":")
    try:
        low, high = float(parts[0]), float(parts[1])
    except (ValueError, IndexError):
        low = high = math.nan
    log = len(parts) == 3 and parts[2] == "log"
    if (not sep or not KEY_PATTERN.fullmatch(key) or "[" in key or len(parts) not in (2, 3)
            or (len(parts) == 3 and not log) or not (math.isfinite(low) and math.isfinite(high)) or low >= high
            or (log and low <= 0)):
        raise StudyError(f"--param expects KEY=LOW:HIGH or KEY=LOW:HIGH:log with finite LOW < HIGH (0 < LOW for log) "
                         f"and KEY a scenario key, e.g. solver.gain=0.5:4:log; got {text!r}")
    return Parameter(key, low, high, log)


@dataclass
class TuneResult:
    """A finished tuning: one row per trial (parameters, value), the best trial, the files written."""

    keys: list[str]
    rows: list[dict]
    best: dict
    files: list[Path] = field(default_factory=list)


def toml_fragment(values: dict[str, Any]) -> str:
    """The best parameters as TOML tables (``solver.gain`` -> ``[solver]`` ``gain = ...``)."""
    tables: dict[str, list[str]] = {}
    for key, value in values.items():
        table, name = key.rsplit(".", 1)
        tables.setdefault(table, []).append(f"{name} = {toml_literal(value)}")
    return "\n\n".join(f"[{table}]\n" + "\n".join(lines) for table, lines in tables.items()) + "\n"


def table_text(rows: Sequence[dict], columns: Sequence[str]) -> str:
    """``tune.csv``: full precision, text that would start a formula neutralised."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(columns)
    writer.writerows([csv_cell(row[c]) for c in columns] for row in rows)
    return buffer.getvalue()


def evaluate(scenario: Path, assignments: list[str], objective: str, samples: Sequence[str], folder: Path,
             study_options: dict) -> tuple[float, dict]:
    """One trial's value: the metric of one run, or the mean metric / pass rate of a study; and its details."""
    from ..runs import run_scenario

    if not samples:
        metrics = run_scenario(scenario, out=folder, overrides=[*assignments, "outputs.figures=false"],
                               progress=False, lock=False).metrics
        passed = bool(metrics["verdict"]["ok"])
        if objective == "pass_rate":
            return float(passed), {"pass_rate": float(passed)}
        return float(metrics.get(objective, math.nan)), {"pass_rate": float(passed)}
    result = study(scenario, samples, out=folder, overrides=assignments, **study_options)
    rate = result.summary["pass_rate"]["rate"]
    if objective == "pass_rate":
        return rate, {"pass_rate": rate}
    values = [row[objective] for row in result.rows if not row["error"] and objective in row]
    finite = [v for v in values if math.isfinite(v)]
    return (sum(finite) / len(finite) if finite else math.nan), {"pass_rate": rate}


def tune(
    scenario: str | os.PathLike,
    parameters: Sequence[str],
    *,
    objective: str = "max_position_error",
    trials: int = 20,
    seed: int = 0,
    samples: Sequence[str] = (),
    study_n: int = 8,
    study_seed: int = 0,
    jobs: int = 1,
    backend: str = "loky",
    scheduler: str | None = None,
    out: str | os.PathLike | None = None,
    overrides: Sequence[str] = (),
    insecure_scheduler: bool = False,
) -> TuneResult:
    """Tune scenario keys with Optuna's TPE sampler; write tune.csv, best.json, best.toml, tune_history.png.

    Args:
        scenario: the TOML file or a shipped scenario name.
        parameters: ``KEY=LOW:HIGH[:log]`` strings (:func:`parse_parameter`).
        objective: a metric of :data:`uvms.scenario.studies.study.METRICS` (minimised) or ``"pass_rate"`` (maximised).
        trials: Optuna trials; seed: the TPE sampler's seed.
        samples: ``KEY=DIST`` strings: every trial is a study of ``study_n`` trials (seed ``study_seed``, the
            method of the scenario's ``[study]`` table: the same disturbances for every trial); empty: one run.
        jobs, backend, scheduler: where the study trials run (:mod:`uvms.scenario.studies.parallel`).
        out: output folder (default ``out/<scenario name>_tune``), replaced whole.
        overrides: ``SECTION.KEY=VALUE`` strings applied to every run.
        insecure_scheduler: accept a ``scheduler`` that is not ``tls://`` (as for
            :func:`uvms.scenario.studies.sweep.sweep`).

    Raises:
        StudyError: bad parameters, objective or trials, Optuna not installed; ScenarioError: a key the
            scenario rejects (checked at the low and the high end of every range before the first trial).
    """
    try:
        import optuna
    except ImportError:
        raise StudyError("uvms tune needs Optuna: pip install uvms[tune]") from None
    scenario = resolve_scenario_path(scenario).resolve()
    tuned = [parse_parameter(text) for text in parameters]
    keys = [p.key for p in tuned]
    if not tuned or len(set(keys)) != len(keys):
        raise StudyError(f"uvms tune needs at least one --param and each key once, got {keys}")
    if objective not in OBJECTIVES:
        raise StudyError(f"objective {objective!r} is not valid; valid: {', '.join(OBJECTIVES)}")
    if not isinstance(trials, int) or not 1 <= trials <= MAX_TUNE_TRIALS:
        raise StudyError(f"uvms tune runs 1 to {MAX_TUNE_TRIALS:,} trials, got {trials!r}")
    check_backend(backend, scheduler, jobs, StudyError, insecure_scheduler)
    if samples:
        parse_samples(samples)  # the distributions' errors before the first trial (the keys: by each study)
    for end in ("low", "high"):  # every key and both ends checked before the first trial
        read_scenario(scenario, [*overrides, *(f"{p.key}={toml_literal(getattr(p, end))}" for p in tuned)])
    name = read_scenario(scenario, overrides).name
    direction = "maximize" if objective == "pass_rate" else "minimize"
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    sampler = optuna.samplers.TPESampler(seed=seed)
    optimisation = optuna.create_study(direction=direction, sampler=sampler)
    options = {"n": study_n, "seed": study_seed, "jobs": jobs, "backend": backend, "scheduler": scheduler,
               "progress": False, "insecure_scheduler": insecure_scheduler}
    rows = []
    from ..runs import run_inputs

    given = Path(out) if out is not None else Path("out") / f"{name}_tune"
    with outputs.run_folder(given, inputs=run_inputs(scenario, [])) as folder:
        (folder / "trials").mkdir()
        for index in range(trials):
            trial = optimisation.ask()
            values = {p.key: trial.suggest_float(p.key, p.low, p.high, log=p.log) for p in tuned}
            assignments = [*overrides, *(f"{key}={toml_literal(value)}" for key, value in values.items())]
            try:
                value, details = evaluate(scenario, assignments, objective, samples,
                                          folder / "trials" / f"trial_{index:04d}", options)
                error = ""
            except StudyError:
                raise
            except Exception as exc:  # noqa: BLE001 - a failed trial is recorded and pruned from the search
                value, details, error = math.nan, {"pass_rate": math.nan}, f"{type(exc).__name__}: {exc}"
            if math.isfinite(value):
                optimisation.tell(trial, value)
            else:
                optimisation.tell(trial, state=optuna.trial.TrialState.FAIL)
            rows.append({"trial": index, **values, "value": value, **details, "error": " ".join(error.split())})
        finished = [row for row in rows if math.isfinite(row["value"])]
        if not finished:
            raise StudyError(f"every one of the {trials} tuning trials failed; the first: {rows[0]['error']}")
        pick = max if direction == "maximize" else min
        best_row = pick(finished, key=lambda row: row["value"])
        best = {"trial": best_row["trial"], "value": best_row["value"], "objective": objective,
                "direction": direction, "parameters": {key: best_row[key] for key in keys},
                "set": [f"{key}={toml_literal(best_row[key])}" for key in keys], "seed": seed,
                "samples": list(samples), "study_n": study_n if samples else 0}
        result = TuneResult(keys=keys, rows=rows, best=best)
        outputs.write_text(folder / "tune.csv", table_text(rows, ["trial", *keys, "value", "pass_rate", "error"]))
        outputs.write_json(folder / "best.json", best)
        outputs.write_text(folder / "best.toml", f"# uvms tune: best {objective} = {best_row['value']:.6g} "
                                                 f"(trial {best_row['trial']})\n" + toml_fragment(best["parameters"]))
        from ...viz.study import save_tune_history

        save_tune_history(rows, keys, objective, direction, folder / "tune_history.png", title=name)
    final = given.resolve()
    result.files = [final / "tune.csv", final / "best.json", final / "best.toml", final / "tune_history.png"]
    return result


__all__ = ["OBJECTIVES", "Parameter", "TuneResult", "parse_parameter", "tune"]
