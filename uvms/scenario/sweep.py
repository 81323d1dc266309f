"""Parameter sweeps of a scenario: a grid of overrides run in parallel, one summary table and one plot.

Every grid point is one :func:`uvms.scenario.run` with ``--set`` style overrides (any scenario key, xacro
args included), executed through joblib: local processes (loky) by default, or the workers of a Dask
cluster (``backend="dask"``, optional extra ``pip install uvms[dask]``). The table is sorted by point
index, so it is the same whatever the backend and the number of jobs.
"""

from __future__ import annotations

import contextlib
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

from .. import outputs
from ..errors import SweepError
from .resources import resolve_scenario_path
from .schema import parse_value, read_scenario, read_toml, scenario_from_raw

#: the metrics of each point in the table (from ``metrics.json`` of its run)
METRICS = ("max_position_error", "final_position_error", "arm_travel", "vehicle_travel", "wall_time")
BACKENDS = ("loky", "dask")
#: The most points of one sweep. Every point is checked before any worker starts (about 0.2 ms a point, a
#: progress bar past one second) and is a whole scenario run (seconds to minutes) with its own folder; a larger
#: study is several sweeps, e.g. one per value of the first key.
MAX_POINTS = 10_000


def parse_grid(text: str) -> tuple[str, list]:
    """``KEY=START:STOP:N`` (N evenly spaced values, ends included) or ``KEY=[a, b, c]`` (TOML list).

    Integers stay integers when START, STOP and the step are whole (e.g. ``model.args.n_joints=4:8:5``).

    Raises:
        SweepError: not of either form, N < 1, a bound not finite, an empty list, a repeated value.
    """
    key, sep, spec = text.partition("=")
    key, spec = key.strip(), spec.strip()
    if not sep or len(key.split(".")) < 2 or not all(key.split(".")) or not spec:
        raise SweepError(f"--grid expects KEY=START:STOP:N or KEY=[a,b,...] (e.g. solver.gain=0.5:2:4), got {text!r}")
    if spec.startswith("["):
        values = parse_value(spec)
        if not isinstance(values, list) or not values or any(isinstance(v, (list, dict)) for v in values):
            raise SweepError(f"--grid {key}: expected a non-empty TOML list of numbers, strings or booleans, got {spec!r}")
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
        """The table as CSV text (floats in full precision)."""
        buffer = io.StringIO()
        writer = csv.writer(buffer, lineterminator="\n")
        writer.writerow(self.columns)
        for row in self.rows:
            writer.writerow([repr(row[c]) if isinstance(row[c], float) else row[c] for c in self.columns])
        return buffer.getvalue()

    def text(self) -> str:
        """The table for a terminal (4 significant digits, errors truncated)."""
        cells = [self.columns] + [[f"{row[c]:.4g}" if isinstance(row[c], float) else str(row[c])[:60]
                                   for c in self.columns] for row in self.rows]
        widths = [max(len(line[i]) for line in cells) for i in range(len(self.columns))]
        return "\n".join("  ".join(cell.ljust(width) for cell, width in zip(line, widths)).rstrip() for line in cells)


def run_point(scenario: str, index: int, assignments: Sequence[str], out: str) -> dict:
    """Run one grid point (in a worker); an exception becomes the row's ``error`` text, metrics NaN."""
    from .runs import run

    use_thread_lock_for_progress_bars()
    row: dict[str, Any] = {"point": index, "error": ""}
    try:
        metrics = run(scenario, out=out, overrides=[*assignments, "outputs.figures=false"], progress=False,
                      lock=False).metrics  # out is inside the sweep's own (locked) temporary folder
        row.update({key: float(metrics.get(key, math.nan)) for key in METRICS})
    except Exception as exc:  # noqa: BLE001 - one failed point must not stop the sweep; it is reported
        row.update({key: math.nan for key in METRICS})
        message = " ".join(str(exc).split())
        row["error"] = f"{type(exc).__name__}: {message}" if message else type(exc).__name__
    return row


def use_thread_lock_for_progress_bars() -> None:
    """In a worker (no progress bar is shown): give tqdm a thread lock instead of its default semaphore.

    tqdm creates an inter-process semaphore on first use; a worker killed by a Ctrl-C never releases it, and
    the parent's resource tracker would then print a "leaked semaphore" warning after the one-line message.
    """
    import threading

    from tqdm.std import tqdm

    if "_lock" not in vars(tqdm):
        tqdm.set_lock(threading.RLock())


@contextlib.contextmanager
def dask_client(scheduler: str | None, jobs: int):
    """A dask.distributed Client on ``scheduler``, or on a local cluster of ``jobs`` worker processes."""
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError:
        raise SweepError("the dask backend needs `pip install uvms[dask]` (dask.distributed)") from None
    try:
        if scheduler:
            client = Client(scheduler, timeout="20s")
        else:
            client = Client(LocalCluster(n_workers=max(jobs, 1), threads_per_worker=1, processes=True,
                                         dashboard_address=None))
    except OSError as exc:
        raise SweepError(f"cannot reach the Dask scheduler {scheduler!r}: {' '.join(str(exc).split())}") from None
    try:
        yield client
    finally:
        cluster = client.cluster if not scheduler else None
        client.close()
        if cluster is not None:
            cluster.close()


def sweep(
    scenario: str | os.PathLike,
    grids: Sequence[tuple[str, list]] | Sequence[str],
    *,
    jobs: int = 1,
    backend: str = "loky",
    scheduler: str | None = None,
    out: str | os.PathLike | None = None,
    progress: bool | None = None,
) -> SweepResult:
    """Run a scenario on every point of a grid; write ``sweep.csv`` and ``sweep.png`` into ``out``.

    Args:
        scenario: the TOML file, or the name of a shipped scenario (``"santos2006_task_priority"``).
        grids: ``(key, values)`` pairs or ``KEY=START:STOP:N`` strings; points are their Cartesian product,
            the first key varying slowest.
        jobs: parallel jobs for loky (-1: all cores); for dask without ``scheduler``, the local workers.
        backend: ``"loky"`` (local processes) or ``"dask"`` (a dask.distributed cluster; its workers must
            see the same files).
        scheduler: address of a Dask scheduler (e.g. ``tcp://10.0.0.5:8786``); None starts a local cluster.
        out: output folder (default ``out/<scenario name>_sweep``); point k runs into ``out/point_k``.
        progress: progress bar (None: on a terminal only).

    Raises:
        SweepError: bad grid, backend or jobs; ScenarioError: a key or value the scenario rejects, found
            before any worker starts.
    """
    scenario = resolve_scenario_path(scenario)
    grids = [parse_grid(g) if isinstance(g, str) else (g[0], list(g[1])) for g in grids]
    keys = [key for key, _ in grids]
    if not grids or len(set(keys)) != len(keys):
        raise SweepError(f"a sweep needs at least one --grid and distinct keys, got {keys}")
    if backend not in BACKENDS:
        raise SweepError(f"backend {backend!r} is not valid; valid: {', '.join(BACKENDS)}")
    if scheduler and backend != "dask":
        raise SweepError(f"a scheduler address ({scheduler!r}) needs the dask backend")
    if not isinstance(jobs, int) or jobs == 0 or jobs < -1:
        raise SweepError(f"jobs must be >= 1 or -1 (all cores), got {jobs!r}")
    count = math.prod(len(values) for _, values in grids)
    if count > MAX_POINTS:
        sizes = " x ".join(f"{len(values):,} ({key})" for key, values in grids)
        raise SweepError(f"the grid has {count:,} points ({sizes}); a sweep has at most {MAX_POINTS:,}: split it "
                         f"into several sweeps (e.g. one per value of {keys[0]}) or take fewer values")
    points = list(itertools.product(*(values for _, values in grids)))
    assignments = [[f"{key}={toml_literal(v)}" for key, v in zip(keys, point)] for point in points]
    checked = check_points(scenario, assignments, progress)
    if any(key.startswith("model.args.") for key in keys):  # xacro args: their names are checked by the model
        from ..model.loader import load

        model = read_scenario(scenario, assignments[0])["model"]
        load(model["path"], base=model["base"] or None, args=model["args"] or None, ee=model["ee"] or None)
    given = Path(out) if out is not None else Path("out") / f"{checked['scenario']['name']}_sweep"
    out = given.resolve()
    width = len(str(len(points) - 1))
    with outputs.run_folder(given) as folder:  # the sweep folder is replaced whole, point folders included
        tasks = [(str(Path(scenario).resolve()), k, overrides, str(folder / f"point_{k:0{width}d}"))
                 for k, overrides in enumerate(assignments)]
        rows = run_tasks(tasks, jobs, backend, scheduler, progress)
        for row, point in zip(rows, points):
            row.update(zip(keys, point))
            row["error"] = row["error"].replace(str(folder), str(out))  # the paths the user will find
        result = SweepResult(keys=keys, rows=rows)
        outputs.write_text(folder / "sweep.csv", result.csv())
        save_sweep_figure(result, folder / "sweep.png", title=checked["scenario"]["name"])
    result.files = [out / "sweep.csv", out / "sweep.png"]
    return result


def check_points(scenario: str | os.PathLike, assignments: list[list[str]], progress: bool | None) -> dict:
    """Check every point's keys and values in the parent, before any worker starts; the last point's scenario.

    The file is parsed once; a progress bar shows up if the checks take more than a second.
    """
    from ..progress import tqdm

    raw = read_toml(scenario)
    checked: dict = {}
    for overrides in tqdm(assignments, desc="checking the grid", unit="point", disable=progress is False,
                          leave=False, delay=1.0):
        checked = scenario_from_raw(raw, scenario, overrides)
    return checked


def run_tasks(tasks: list[tuple], jobs: int, backend: str, scheduler: str | None, progress: bool | None) -> list[dict]:
    """Run the points through joblib (loky or dask); rows sorted by point index."""
    from joblib import Parallel, delayed, parallel_config
    from ..progress import tqdm

    def execute() -> list[dict]:
        parallel = Parallel(n_jobs=jobs, return_as="generator")
        results = parallel(delayed(run_point)(*task) for task in tasks)
        try:
            return list(tqdm(results, total=len(tasks), desc="sweep", unit="point", disable=progress is False,
                             leave=False))
        except BaseException:  # Ctrl-C or an error: no worker may go on writing into the sweep folder
            stop_workers(results)
            raise

    if backend == "dask":
        with dask_client(scheduler, jobs), parallel_config(backend="dask"):
            rows = execute()
    else:
        with parallel_config(backend="loky"):
            rows = execute()
    return sorted(rows, key=lambda row: row["point"])


def stop_workers(results) -> None:
    """Abort a joblib generator and kill the loky workers (before the sweep's temporary folder is removed).

    Closing the generator makes joblib abort its backend, which for loky shuts the executor down with
    ``kill_workers=True`` and waits for the workers to exit; then any reusable loky executor left is shut down the
    same way. A Dask cluster is closed by :func:`dask_client`.
    """
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # joblib warns that the generator was exited early: that is the point
        with contextlib.suppress(Exception):
            results.close()
        with contextlib.suppress(Exception):
            from joblib.externals.loky import reusable_executor

            executor = getattr(reusable_executor, "_executor", None)
            if executor is not None:
                executor.shutdown(wait=True, kill_workers=True)


def save_sweep_figure(result: SweepResult, path: Path, title: str = "") -> None:
    """Each metric against the first grid key, one line per combination of the other keys (NaN: failed)."""
    from matplotlib.figure import Figure

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
            label = ", ".join(f"{key.split('.')[-1]}={value}" for key, value in zip(others, group)) or None
            axis.plot(x, [row[metric] for row in rows], "o-", label=label)
        axis.set_ylabel(metric.replace("_", " "), fontsize=8)
        axis.grid(True, alpha=0.3)
    if others:
        axes[0].legend(fontsize=7)
    if not numeric:
        axes[-1].set_xticks(range(len(categories)), [str(c) for c in categories])
    axes[-1].set_xlabel(first)
    failed = len(result.failed)
    figure.suptitle(f"{title}: sweep of {len(result.rows)} points" + (f" ({failed} failed)" if failed else ""))
    figure.tight_layout()
    outputs.save_figure(figure, path)


__all__ = ["METRICS", "SweepError", "SweepResult", "parse_grid", "sweep"]
