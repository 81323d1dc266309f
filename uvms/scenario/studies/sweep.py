"""Parameter sweeps of a scenario: a grid of overrides run in parallel, one summary table and one plot.

Every grid point is one :func:`uvms.scenario.run_scenario` with ``--set`` style overrides (any scenario key, xacro
args included), executed through joblib: local processes (loky) by default, or the workers of a Dask
cluster (``backend="dask"``, optional extra ``pip install uvms[dask]``), by :mod:`uvms.scenario.studies.parallel`
(the local TLS cluster, remote schedulers, worker counts). The table is sorted by point index, so it is the same
whatever the backend and the number of jobs.
"""

from __future__ import annotations

import csv
import io
import itertools
import json
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ...errors import SweepError
from ...io import outputs
from ..record import scenario_model
from ..resources import resolve_scenario_path
from ..schema import parse_value, read_scenario, read_toml, scenario_from_raw
from ..spec import ScenarioSpec
from .parallel import check_backend, run_tasks, use_thread_lock_for_progress_bars

#: the metrics of each point in the table (from ``metrics.json`` of its run)
METRICS = ("max_position_error", "final_position_error", "arm_travel", "vehicle_travel", "wall_time")
#: The most points of one sweep. Every point is checked before any worker starts (about 0.2 ms a point, a
#: progress bar past one second) and is a whole scenario run (seconds to minutes) with its own folder; a larger
#: study is several sweeps, e.g. one per value of the first key.
MAX_POINTS = 10_000
#: A text cell starting with one of these is a formula to a spreadsheet: ``sweep.csv`` prefixes it with ``'``.
FORMULA_START = ("=", "+", "-", "@", "\t", "\r")


def parse_grid(text: str) -> tuple[str, list]:
    """``KEY=START:STOP:N`` (N evenly spaced values, ends included) or ``KEY=[a, b, c]`` (TOML list).

    Integers stay integers when START, STOP and the step are whole (e.g. ``model.args.n_joints=4:8:5``).

    Raises:
        SweepError: not of either form, N < 1, a bound not finite, an empty list, a repeated value, a line break.
    """
    key, sep, spec = text.partition("=")
    key, spec = key.strip(), spec.strip()
    if not sep or len(key.split(".")) < 2 or not all(key.split(".")) or not spec:
        raise SweepError(f"--grid expects KEY=START:STOP:N or KEY=[a,b,...] (e.g. solver.gain=0.5:2:4), got {text!r}")
    if spec.startswith("["):
        values = parse_value(spec)
        if not isinstance(values, list) or not values or any(isinstance(v, (list, dict)) for v in values):
            raise SweepError(f"--grid {key}: expected a non-empty TOML list "
                             f"of numbers, strings or booleans, got {spec!r}")
        if any(isinstance(v, str) and any(c in v for c in "\r\n\x0b\x0c") for v in values):  # a row per point
            raise SweepError(f"--grid {key}: a string value holds a line break; values are one-line, got {spec!r}")
    else:
        parts = spec.split(":")
        try:
            start, stop, count = float(parts[0]), float(parts[1]), int(parts[2])
        except (ValueError, IndexError):
            parts = []
        if len(parts) != 3 or count < 1 or not (math.isfinite(start) and math.isfinite(stop)):
            raise SweepError(f"--grid {key}: expected START:STOP:N with finite START, STOP and an integer N >= 1, "
                             f"got {spec!r}")
        if count > MAX_POINTS:
            raise SweepError(f"--grid {key}: N = {count:,} values; a sweep has at most {MAX_POINTS:,} points")
        values = [float(v) for v in np.linspace(start, stop, count)]
        step = (stop - start) / (count - 1) if count > 1 else 0.0
        if all("." not in p and "e" not in p.lower() for p in parts[:2]) and step == int(step):
            values = [round(v) for v in values]
    if len({json.dumps(v) for v in values}) != len(values):
        raise SweepError(f"--grid {key}: repeated values {values}")
    return key, values


def toml_literal(value: Any) -> str:
    """A grid value as a TOML literal for ``--set``."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value)  # a TOML basic string
    return repr(value)


@dataclass
class SweepResult:
    """A finished sweep: one row per grid point (grid values, metrics, ``error``), and the files written."""

    keys: list[str]
    rows: list[dict]
    files: list[Path] = field(default_factory=list)

    @property
    def columns(self) -> list[str]:
        """Column names of the table, in order."""
        return ["point", *self.keys, *METRICS, "error"]

    @property
    def failed(self) -> list[dict]:
        """The rows of the points whose run raised (their metrics are NaN)."""
        return [row for row in self.rows if row["error"]]

    def csv(self) -> str:
        """The table as CSV text (:func:`csv_cell`)."""
        buffer = io.StringIO()
        writer = csv.writer(buffer, lineterminator="\n")
        writer.writerow([csv_cell(c) for c in self.columns])
        for row in self.rows:
            writer.writerow([csv_cell(row[c]) for c in self.columns])
        return buffer.getvalue()

    def text(self) -> str:
        """The table for a terminal (4 significant digits, errors truncated)."""
        cells = [self.columns] + [[f"{row[c]:.4g}" if isinstance(row[c], float) else str(row[c])[:60]
                                   for c in self.columns] for row in self.rows]
        widths = [max(len(line[i]) for line in cells) for i in range(len(self.columns))]
        return "\n".join("  ".join(cell.ljust(width) for cell, width in zip(line, widths)).rstrip() for line in cells)


def csv_cell(value: Any) -> Any:
    """A cell of ``sweep.csv``: a float in full precision, text neutralised if it would start a formula."""
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, str) and value.startswith(FORMULA_START):
        return "'" + value
    return value


def run_point(scenario: str, index: int, assignments: Sequence[str], out: str) -> dict:
    """Run one grid point (in a worker); an exception becomes the row's ``error`` text, metrics NaN."""
    from ..runs import run_scenario

    use_thread_lock_for_progress_bars()
    row: dict[str, Any] = {"point": index, "error": ""}
    try:
        metrics = run_scenario(scenario, out=out, overrides=[*assignments, "outputs.figures=false"], progress=False,
                      lock=False).metrics  # out is inside the sweep's own (locked) temporary folder
        row.update({key: float(metrics.get(key, math.nan)) for key in METRICS})
    except Exception as exc:  # noqa: BLE001 - one failed point must not stop the sweep; it is reported
        row.update({key: math.nan for key in METRICS})
        message = " ".join(str(exc).split())
        row["error"] = f"{type(exc).__name__}: {message}" if message else type(exc).__name__
    return row


def sweep(
    scenario: str | os.PathLike,
    grids: Sequence[tuple[str, list]] | Sequence[str],
    *,
    jobs: int = 1,
    backend: str = "loky",
    scheduler: str | None = None,
    out: str | os.PathLike | None = None,
    progress: bool | None = None,
    overrides: Sequence[str] = (),
    insecure_scheduler: bool = False,
) -> SweepResult:
    """Run a scenario on every point of a grid; write ``sweep.csv`` and ``sweep.png`` into ``out``.

    Args:
        scenario: the TOML file, or the name of a shipped scenario (``"santos2006_task_priority"``).
        grids: ``(key, values)`` pairs or ``KEY=START:STOP:N`` strings; points are their Cartesian product,
            the first key varying slowest.
        jobs: parallel jobs for loky (-1: all cores); for dask without ``scheduler``, the local workers;
            locally at most one per point and per core (:func:`uvms.scenario.studies.parallel.worker_count`).
        backend: ``"loky"`` (local processes) or ``"dask"`` (a dask.distributed cluster; its workers must
            see the same files).
        scheduler: address of a Dask scheduler, ``tls://`` with credentials from Dask's configuration (e.g.
            ``tls://10.0.0.5:8786``); None starts a local TLS cluster.
        out: output folder (default ``out/<scenario name>_sweep``); point k runs into ``out/point_k``.
        progress: progress bar (None: on a terminal only).
        overrides: ``SECTION.KEY=VALUE`` strings applied to every point before its grid values.
        insecure_scheduler: accept a ``scheduler`` that is not ``tls://`` (``tcp://``): anyone who can reach it
            can run code on its workers and in this process (:data:`uvms.scenario.studies.parallel.OPEN_SCHEDULER`).

    Raises:
        SweepError: bad grid, backend or jobs, a scheduler that is not tls:// without ``insecure_scheduler``;
        ScenarioError: a key or value the scenario rejects, found
            before any worker starts.
    """
    scenario = resolve_scenario_path(scenario)
    grids = [parse_grid(g) if isinstance(g, str) else (g[0], list(g[1])) for g in grids]
    keys = [key for key, _ in grids]
    if not grids or len(set(keys)) != len(keys):
        raise SweepError(f"a sweep needs at least one --grid and distinct keys, got {keys}")
    check_backend(backend, scheduler, jobs, SweepError, insecure_scheduler)
    count = math.prod(len(values) for _, values in grids)
    if count > MAX_POINTS:
        sizes = " x ".join(f"{len(values):,} ({key})" for key, values in grids)
        raise SweepError(f"the grid has {count:,} points ({sizes}); a sweep has at most {MAX_POINTS:,}: split it "
                         f"into several sweeps (e.g. one per value of {keys[0]}) or take fewer values")
    points = list(itertools.product(*(values for _, values in grids)))
    assignments = [[*overrides, *(f"{key}={toml_literal(v)}" for key, v in zip(keys, point))] for point in points]
    checked, models, files = check_points(scenario, assignments, progress)
    if any(key.startswith("model.args.") for key in keys):  # xacro args: their names are checked by the model
        scenario_model(read_scenario(scenario, assignments[0]).model)
    given = Path(out) if out is not None else Path("out") / f"{checked.name}_sweep"
    out = given.resolve()
    width = len(str(len(points) - 1))
    from ..runs import run_inputs

    inputs = run_inputs(scenario, models, files)
    with outputs.run_folder(given, inputs=inputs) as folder:  # replaced whole, point folders included
        tasks = [(str(Path(scenario).resolve()), k, overrides, str(folder / f"point_{k:0{width}d}"))
                 for k, overrides in enumerate(assignments)]
        rows = sorted(run_tasks(run_point, tasks, jobs=jobs, backend=backend, scheduler=scheduler, progress=progress,
                                error=SweepError, desc="sweep", insecure_scheduler=insecure_scheduler),
                      key=lambda row: row["point"])
        for row, point in zip(rows, points):
            row.update(zip(keys, point))
            row["error"] = row["error"].replace(str(folder), str(out))  # the paths the user will find
        result = SweepResult(keys=keys, rows=rows)
        outputs.write_text(folder / "sweep.csv", result.csv())
        save_sweep_figure(result, folder / "sweep.png", title=checked.name)
    result.files = [out / "sweep.csv", out / "sweep.png"]
    return result


def check_points(scenario: str | os.PathLike, assignments: list[list[str]],
                 progress: bool | None) -> tuple[ScenarioSpec | None, list[str], list[str]]:
    """Check every point's keys and values in the parent, before any worker starts.

    The file is parsed once; a progress bar shows up if the checks take more than a second.

    Returns:
        The last point's scenario, the model paths of all points (``model.path`` may be a grid key) and the other
        files they name (:meth:`~uvms.scenario.spec.ScenarioSpec.named_files`).
    """
    from ...io.progress import tqdm

    raw = read_toml(scenario)
    checked: ScenarioSpec | None = None
    models: dict[str, None] = {}
    files: dict[str, None] = {}
    for overrides in tqdm(assignments, desc="checking the grid", unit="point", disable=progress is False,
                          leave=False, delay=1.0):
        checked = scenario_from_raw(raw, scenario, overrides)
        models[checked.model.path] = None
        files.update(dict.fromkeys(checked.named_files()))
    return checked, list(models), list(files)


def save_sweep_figure(result: SweepResult, path: Path, title: str = "") -> None:
    """Each metric against the first grid key, one line per combination of the other keys (NaN: failed)."""
    from matplotlib.figure import Figure

    from ...viz.labels import plain_text

    first, others = result.keys[0], result.keys[1:]
    xs = [row[first] for row in result.rows]
    numeric = all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in xs)
    categories = list(dict.fromkeys(xs))
    groups: dict[tuple, list[dict]] = {}
    for row in result.rows:
        groups.setdefault(tuple(row[key] for key in others), []).append(row)
    figure = Figure(figsize=(7, 2.0 * len(METRICS) + 0.6))
    axes = figure.subplots(len(METRICS), 1, sharex=True, squeeze=False)[:, 0]
    for axis, metric in zip(axes, METRICS):
        for group, rows in groups.items():
            x = [row[first] if numeric else categories.index(row[first]) for row in rows]
            label = ", ".join(plain_text(f"{key.split('.')[-1]}={value}")
                              for key, value in zip(others, group)) or None
            axis.plot(x, [row[metric] for row in rows], "o-", label=label)
        axis.set_ylabel(metric.replace("_", " "), fontsize=8)
        axis.grid(True, alpha=0.3)
    if others:
        axes[0].legend(fontsize=7)
    if not numeric:
        axes[-1].set_xticks(range(len(categories)), [plain_text(c) for c in categories])
    axes[-1].set_xlabel(plain_text(first))
    failed = len(result.failed)
    figure.suptitle(f"{plain_text(title)}: sweep of {len(result.rows)} points"
                    + (f" ({failed} failed)" if failed else ""))
    figure.tight_layout()
    outputs.save_figure(figure, path)


__all__ = ["METRICS", "SweepError", "SweepResult", "parse_grid", "sweep"]
