"""The folder of a Monte Carlo study (:mod:`uvms.scenario.studies.study`): its lock and spec, and the rows a resume
reuses.

A study folder holds ``study.json`` (the spec), ``trials/trial_k.json`` (the row of trial k) and
``trials/trial_k/`` (its run folder), all written by uvms. A resume trusts none of it blindly:

- a symbolic link anywhere among them is refused (one-line :class:`~uvms.errors.StudyError`): uvms never makes
  one, and writing the trial's run through it would replace whatever it points to;
- files are read only if they are regular files inside the folder, at most
  :data:`uvms.model.resources.MAX_JSON_BYTES` each;
- a row is reused only if it is the trial it claims: its index, seed and sampled values recomputed from the
  spec, every field of its type, and a finished run's metrics, verdict and wall time equal to those of the
  ``metrics.json`` in its run folder. Any other row (edited by hand, truncated, copied from another trial) is set
  aside with one :class:`~uvms.errors.StudyResumeWarning` naming the trials and why, and the trial runs again:
  the table is then the one a study run without interruption gives.
"""

from __future__ import annotations

import json
import os
import shutil
import stat
from collections.abc import Callable, Sequence
from pathlib import Path

from ...errors import StudyError, StudyResumeWarning
from ...io import outputs
from ...model.resources import read_json

#: the metrics of each trial (from ``metrics.json``; one absent from every trial is left out of the table)
METRICS = ("max_position_error", "final_position_error", "rms_position_error", "max_orientation_error",
           "max_vehicle_tilt", "max_joint_limit_violation")
SPEC = "study.json"
TRIALS = "trials"
#: the fields of a row (``trials/trial_k.json``)
ROW_FIELDS = frozenset({"trial", "seed", "values", "error", "pass", "wall_time", *METRICS})
SHOWN = 5  # set-aside rows a warning names


def trial_name(index: int) -> str:
    """``trial_00012``: the run folder of trial 12 (``.json``: its row)."""
    return f"trial_{index:05d}"


def refuse_links(final: Path, shown: str) -> None:
    """Refuse a study folder whose spec, trials folder or any entry of its trials folder is a symbolic link.

    Raises:
        StudyError: naming the first link found.
    """
    trials = final / TRIALS
    links = [path for path in (final / SPEC, trials) if path.is_symlink()]
    if not links and trials.is_dir():
        with os.scandir(trials) as entries:
            links = [Path(entry.path) for entry in entries if entry.is_symlink()]
    if links:
        raise StudyError(f"{str(links[0])!r} in the study folder {shown!r} is a symbolic link, which uvms never "
                         f"makes there (a resumed study would write through it into its target); remove it or "
                         f"choose another --out")
    if os.path.lexists(trials) and not trials.is_dir():
        raise StudyError(f"{str(trials)!r} is not a folder; {shown!r} is not a study folder uvms wrote: choose "
                         f"another --out")


def open_study_folder(folder: Path, spec: dict) -> Callable[[], None]:
    """Lock ``folder``, refuse it if it holds anything but this study, write the spec; return the lock's release.

    Raises:
        StudyError: ``folder`` is a file, holds another study (the differing fields named), other files, or a
            symbolic link (:func:`refuse_links`).
    """
    shown = os.fspath(folder)
    final = Path(os.path.realpath(os.path.abspath(folder)))
    final.parent.mkdir(parents=True, exist_ok=True)
    release = outputs.hold_lock(final.parent / f".{final.name}{outputs.LOCK_SUFFIX}", shown)
    try:
        if os.path.lexists(final) and not final.is_dir():
            raise StudyError(f"{shown!r} is a file, not a study folder; choose another --out")
        refuse_links(final, shown)
        stored = final / SPEC
        if stored.is_file():
            try:
                previous = read_json(stored, "study spec", StudyError)
            except StudyError:
                previous = None
            if previous != spec:
                previous = previous if isinstance(previous, dict) else {}
                fields = sorted(k for k in {*spec, *previous} if previous.get(k) != spec.get(k))
                raise StudyError(f"{shown!r} holds another study (it differs in {', '.join(fields)}); a study folder "
                                 f"holds one study, resumed only with the same spec: choose another --out, or "
                                 f"delete the folder to start over")
        elif final.is_dir() and any(final.iterdir()):
            raise StudyError(f"{shown!r} exists and is not a study folder (no {SPEC}); a study writes only into a "
                             f"new or empty folder, or resumes its own")
        else:
            (final / TRIALS).mkdir(parents=True, exist_ok=True)
            outputs.write_json(stored, spec)
        (final / TRIALS).mkdir(exist_ok=True)
        # of killed trials (ours: we hold the lock): run folders being written, rows being written
        for pattern in (f".trial_*{outputs.TEMPORARY_MARK}*", ".trial_*.json.*.tmp"):
            for stale in (final / TRIALS).glob(pattern):
                if stale.is_dir():
                    shutil.rmtree(stale, ignore_errors=True)
                else:
                    stale.unlink(missing_ok=True)
    except BaseException:
        release()
        raise
    return release


def read_regular_json(path: Path) -> object:
    """The JSON document of ``path`` if it is a regular file (never through a link); None if absent.

    Raises:
        StudyError: not a regular file, too large, not UTF-8 JSON.
    """
    try:
        mode = os.lstat(path).st_mode
    except FileNotFoundError:
        return None
    if not stat.S_ISREG(mode):
        raise StudyError(f"{path}: not a regular file")
    return read_json(path, "study row", StudyError)


def row_problem(row: object, index: int, seed: int, sampled: list, trials: Path) -> str:
    """Why ``row`` is not the row of trial ``index`` (seed ``seed``, values ``sampled``); "" if it is."""
    if not isinstance(row, dict):
        return "not a JSON object"
    if set(row) - ROW_FIELDS:
        return f"unknown fields {', '.join(sorted(set(row) - ROW_FIELDS))}"
    if type(row.get("trial")) is not int or row["trial"] != index:
        return f"it claims trial {row.get('trial')!r}"
    if type(row.get("seed")) is not int or row["seed"] != seed or row.get("values") != json.loads(json.dumps(sampled)):
        return "its seed or sampled values are not this trial's"
    if type(row.get("pass")) is not bool or not isinstance(row.get("error"), str):
        return "no boolean pass or text error"
    present = {key: row[key] for key in row if key in METRICS or key == "wall_time"}
    if any(type(value) is not float for value in present.values()):
        return "a metric or wall_time that is not a number"
    if row["error"]:  # a failed or killed trial: its error text, no metric
        return "a failed trial with metrics or passed" if row["pass"] or set(present) - {"wall_time"} else ""
    try:
        metrics = read_regular_json(trials / trial_name(index) / "metrics.json")
        expected = {key: float(metrics[key]) for key in (*METRICS, "wall_time") if key in metrics}
        passed = bool(metrics["verdict"]["ok"])
    except (StudyError, TypeError, KeyError, ValueError):
        return f"its run folder {trial_name(index)} has no readable metrics.json"
    if json.dumps(present, sort_keys=True) != json.dumps(expected, sort_keys=True) or row["pass"] != passed:
        return f"its metrics or verdict differ from those of {trial_name(index)}/metrics.json"
    return ""


def finished_rows(trials: Path, seeds: Sequence[int], values: Sequence[list],
                  warn: bool = False) -> dict[int, dict]:
    """The rows found in ``trials`` that are the trials they claim (:func:`row_problem`); the others run again
    (``warn``: one :class:`~uvms.errors.StudyResumeWarning` naming them)."""
    import warnings

    rows, problems = {}, {}
    for index, (seed, sampled) in enumerate(zip(seeds, values)):
        try:
            row = read_regular_json(trials / f"{trial_name(index)}.json")
        except StudyError as exc:
            row, problem = None, f"unreadable ({' '.join(str(exc).split()).rsplit(': ', 1)[-1]})"
        else:
            problem = "" if row is None else row_problem(row, index, seed, sampled, trials)
        if problem:
            problems[index] = problem
        elif row is not None:
            rows[index] = row
    if problems and warn:
        named = "; ".join(f"trial {k}: {why}" for k, why in list(problems.items())[:SHOWN])
        more = f"; and {len(problems) - SHOWN} more" if len(problems) > SHOWN else ""
        warnings.warn(f"{len(problems)} row(s) in {trials} are not the trials they claim and are run again "
                      f"({named}{more})", StudyResumeWarning, stacklevel=3)
    return rows


def started_by(folder: Path, index: int, token: str) -> bool:
    """Whether trial ``index`` was started by the batch ``token`` (its marker file)."""
    marker = folder / f"{trial_name(index)}.started"
    try:
        return stat.S_ISREG(os.lstat(marker).st_mode) and marker.read_text(encoding="utf-8") == token
    except (OSError, UnicodeDecodeError):
        return False


def killed_row(folder: Path, index: int, seed: int, values: list, exc: BaseException) -> dict:
    """The row of a trial whose worker died twice (written like any row: it is not run again on resume)."""
    message = " ".join(str(exc).split())[:300]
    row = {"trial": index, "seed": seed, "values": values, "pass": False,
           "error": f"killed: the worker running this trial died, twice ({type(exc).__name__}: {message})"}
    outputs.write_json(folder / f"{trial_name(index)}.json", row)
    return row


__all__ = ["METRICS", "SPEC", "TRIALS", "finished_rows", "killed_row", "open_study_folder", "row_problem",
           "started_by", "trial_name"]
