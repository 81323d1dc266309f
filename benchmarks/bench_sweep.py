"""Parallel efficiency of `uvms sweep`: runs per second on all cores over the cores times the one-process rate.

The issue's row: a sweep of 64 `hoang2011_w1` variants (``solver.gain`` from 0.5 to 2.0, figures off) with
``--jobs 1`` (in this process), with loky's worker processes on every core, and on a local Dask cluster with as
many workers. Efficiency = (runs/s with J jobs) / (J x runs/s with one job); the three tables must be equal
(every metric of every point, wall times aside).

    python benchmarks/bench_sweep.py [--points 64] [--jobs 2]     # about 5 min on 2 free cores

The cores must be free: another process on them is time the workers do not get, and the efficiency then measures
the machine (the load average is printed before and after each sweep).
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import numpy as np

from uvms.scenario.studies.sweep import METRICS, sweep

ROOT = Path(__file__).resolve().parent.parent


def timed_sweep(points: int, jobs: int, backend: str, out: Path) -> tuple[float, list[dict]]:
    """(wall time [s], rows) of the sweep of ``points`` gains of hoang2011_w1 with ``jobs`` on ``backend``."""
    gains = [float(g) for g in np.linspace(0.5, 2.0, points)]
    started = time.perf_counter()
    result = sweep(ROOT / "scenarios" / "hoang2011_w1.toml", [("solver.gain", gains)], jobs=jobs, backend=backend,
                   out=out, progress=False, overrides=["outputs.figures=false"])
    return time.perf_counter() - started, result.rows


def table(rows: list[dict]) -> list[tuple]:
    """The metrics of every point, in point order (what must not depend on the backend)."""
    return [(row["point"], *(row[m] for m in METRICS if m != "wall_time"), row["error"]) for row in rows]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=64)
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    args = parser.parse_args()
    timed_sweep(2, 1, "loky", Path(tempfile.mkdtemp()) / "warm")  # this process's imports and kernels loaded
    rates, tables = {}, {}
    with tempfile.TemporaryDirectory() as folder:
        for label, jobs, backend in (("one process", 1, "loky"), (f"loky, {args.jobs} jobs", args.jobs, "loky"),
                                     (f"dask local cluster, {args.jobs} workers", args.jobs, "dask")):
            load = os.getloadavg()[0]
            wall, rows = timed_sweep(args.points, jobs, backend, Path(folder) / label.split(",")[0].replace(" ", "_"))
            rates[label], tables[label] = (args.points / wall, jobs), table(rows)
            print(f"{label:36s} {wall:7.1f} s  {args.points / wall:6.3f} runs/s  (load {load:.1f} -> "
                  f"{os.getloadavg()[0]:.1f})", flush=True)
    single = rates["one process"][0]
    for label, (rate, jobs) in rates.items():
        if jobs > 1:
            same = tables[label] == tables["one process"]
            print(f"{label:36s} efficiency {rate / (jobs * single):.2f}  table equal to one process's: {same}")


if __name__ == "__main__":
    main()
