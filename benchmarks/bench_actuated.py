"""The actuated chain's step, a study of it and the fixed cost of a run (issue 46), as ratios to ``pin.aba``.

Rows:

* the intervention step (``scenarios/bluerov2_alpha5_intervention.toml``: set-based solve and the coordination's
  re-solve, the vehicle loops, the allocation, 4 RK4 stages of the hydrodynamic plant, the record): the scenario
  built once, its 1,000-step loop run in this process, per step as a ratio to one ``pin.aba`` (and ``pin.crba``)
  on the same model timed beside each loop (median over the rounds);
* the same step's compiled calls alone, replayed back to back (``step_floor.py``): the step with no Python; and the
  thin step: each of them through one Python function that makes one array (the least Python between them);
* ``uvms run bluerov2_alpha5_intervention`` and ``uvms run hoang2011_w1`` with figures off, fresh processes, wall;
* ``uvms study bluerov2_alpha5_intervention --jobs 2`` (``--trials`` trials): trials per second.

Before/after: run the same script with ``PYTHONPATH=OLD_TREE`` (the checkout imported is the one timed).

    python benchmarks/bench_actuated.py [--rounds 3] [--trials 8] [--no-study]
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
import timeit
from pathlib import Path

import numpy as np
import pinocchio as pin

import uvms

ROOT = Path(uvms.__file__).resolve().parent.parent  # the checkout imported (PYTHONPATH=OLD_TREE: before/after)
SCENARIO = ROOT / "scenarios" / "bluerov2_alpha5_intervention.toml"


def reference_times(robot: uvms.Robot, number: int = 2000) -> tuple[float, float]:
    """(one pin.aba, one pin.crba) [s] on the robot's model at a random state, best of 5."""
    model, data = robot.model, robot.model.createData()
    rng = np.random.default_rng(0)
    q = pin.integrate(model, robot.neutral(), 0.3 * rng.normal(size=robot.nv))
    v, tau = 0.3 * rng.normal(size=robot.nv), np.zeros(robot.nv)
    aba = min(timeit.repeat(lambda: pin.aba(model, data, q, v, tau), number=number, repeat=5)) / number
    crba = min(timeit.repeat(lambda: pin.crba(model, data, q), number=number, repeat=5)) / number
    return aba, crba


def step_rows(rounds: int) -> list[tuple[str, str]]:
    """The intervention's loop in this process: per step [ms] and as ratios to pin.aba, pin.crba."""
    from uvms.scenario.actuated import simulate_actuation
    from uvms.scenario.build import build
    from uvms.scenario.schema import read_scenario

    spec = read_scenario(SCENARIO, ["outputs.figures=false"])
    setup = build(spec)
    samples = getattr(setup, "samples", None) or setup.trajectory
    per_step, ratios, crba_ratios, abas = [], [], [], []
    for _ in range(rounds + 1):  # the first loop loads the kernels: not counted
        aba, crba = reference_times(setup.robot)
        result = simulate_actuation(setup.actuation, setup.task, samples, setup.q0, setup.duration, spec.simulation,
                                    False)
        aba2, crba2 = reference_times(setup.robot)
        step = result.wall_time / (len(result.t) - 1)
        per_step.append(step)
        ratios.append(step / (0.5 * (aba + aba2)))
        crba_ratios.append(step / (0.5 * (crba + crba2)))
        abas.append(0.5 * (aba + aba2))
    per_step, ratios, crba_ratios, abas = per_step[1:], ratios[1:], crba_ratios[1:], abas[1:]
    steps = len(result.t) - 1
    return [(f"intervention step (pin.aba {1e6 * np.median(abas):.2f} us)",
             f"{1e3 * np.median(per_step):.3f} ms = **{np.median(ratios):.0f}x aba** "
             f"({', '.join(f'{r:.0f}' for r in ratios)}), {np.median(crba_ratios):.0f}x crba"),
            (f"... its loop ({steps} steps)", f"{steps * np.median(per_step):.2f} s")]


def floor_rows(rounds: int) -> list[tuple[str, str]]:
    """The same step's compiled calls alone, replayed back to back (``step_floor.py``, in a process of its own: it
    wraps numba's and Pinocchio's calls): the step with all of its Python taken away, its numerics bit for bit; and
    the thin step, each of those calls made through one Python function that makes one array (an older
    ``step_floor.py`` has no thin row)."""
    output = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "step_floor.py"), "--json", "--rounds",
                             str(rounds)], cwd=ROOT, capture_output=True, check=True, text=True).stdout
    times = json.loads(output.splitlines()[-1])
    rows = []
    for key, label in (("step", "... its compiled calls alone, replayed (`step_floor.py`)"),
                       ("thin", "... those calls through one Python function each (the thin step)")):
        if key in times:
            ratios = [step / aba for step, aba in zip(times[key], times["aba"])]
            rows.append((label, f"{1e3 * np.median(times[key]):.3f} ms = **{np.median(ratios):.0f}x aba** "
                                f"({', '.join(f'{r:.0f}' for r in ratios)})"))
    return rows


def run_wall(scenario: str, repeat: int) -> tuple[str, str]:
    """``uvms run SCENARIO`` figures off in fresh processes: median wall [s] (min-max)."""
    out = Path(tempfile.mkdtemp(prefix="uvms_bench_actuated_"))
    command = [sys.executable, "-m", "uvms.cli", "run", str(ROOT / "scenarios" / f"{scenario}.toml"), "--out",
               str(out / "run"), "--set", "outputs.figures=false", "--quiet"]
    walls = []
    for _ in range(repeat):
        started = time.perf_counter()
        subprocess.run(command, cwd=ROOT, capture_output=True, check=True)
        walls.append(time.perf_counter() - started)
    shutil.rmtree(out, ignore_errors=True)
    return (f"`uvms run {scenario}`, figures off, wall",
            f"{np.median(walls):.2f} s ({min(walls):.2f}-{max(walls):.2f})")


def study_row(trials: int, jobs: int) -> tuple[str, str]:
    """``uvms study bluerov2_alpha5_intervention -n N --jobs J`` in a fresh process: trials per second."""
    out = Path(tempfile.mkdtemp(prefix="uvms_bench_study_"))
    command = [sys.executable, "-m", "uvms.cli", "study", str(SCENARIO), "-n", str(trials), "--jobs",
               str(jobs), "--out", str(out / "study"), "--quiet"]
    started = time.perf_counter()
    subprocess.run(command, cwd=ROOT, capture_output=True, check=True)
    wall = time.perf_counter() - started
    summary = json.loads((out / "study" / "summary.json").read_text())
    shutil.rmtree(out, ignore_errors=True)
    return (f"`uvms study bluerov2_alpha5_intervention -n {trials} --jobs {jobs}`",
            f"{trials / wall:.2f} trials/s ({wall:.1f} s wall; trials' own time {summary['wall_time']:.1f} s)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3, help="loops of the intervention timed (after a first)")
    parser.add_argument("--runs", type=int, default=3, help="fresh `uvms run` processes per scenario")
    parser.add_argument("--trials", type=int, default=8, help="trials of the study row")
    parser.add_argument("--jobs", type=int, default=2, help="jobs of the study row")
    parser.add_argument("--no-study", action="store_true", help="leave the study row out")
    options = parser.parse_args()
    rows = step_rows(options.rounds)
    if (ROOT / "benchmarks" / "step_floor.py").exists():  # an older checkout may not have it
        rows += floor_rows(options.rounds)
    rows += [run_wall("bluerov2_alpha5_intervention", options.runs), run_wall("hoang2011_w1", options.runs)]
    if not options.no_study:
        rows.append(study_row(options.trials, options.jobs))
    print(f"checkout {ROOT}")
    for label, value in rows:
        print(f"| {label} | {value} |")


if __name__ == "__main__":
    main()
