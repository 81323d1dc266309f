"""The speed issue's table in one run: every row of issue 16, uvms next to pink and roboticstoolbox where installed.

Rows (goals of the issue in the last column):

* the general CLIK step and the pose-task ``CLIKSolver.step`` (UR5 on a 6-DOF floating base, nv = 12;
  ``bench_clik.py``);
* the set-based step (BlueROV2 + Alpha 5: joint limits, speed limits, attitude, pose; ``bench_set_based.py``),
  beside pink's ``solve_ik`` with configuration and velocity limits;
* ``uvms run scenarios/hoang2011_w1.toml`` with figures off, as a user runs it (fresh processes, wall time), and the
  time up to its loop (import + load + build);
* pose IK by the TRAC-IK protocol at 1e-10, joint limits on (``bench_ik.py``), beside roboticstoolbox's ``ik_LM``;
* the Monte Carlo workspace of both xiang2019 arms, 1 M samples each, volumes and with dexterity.

Step times are ratios to one ``pin.forwardKinematics`` on the same model, measured in the same run (the
machines are shared and noisy: absolute times are not comparable between runs). placo pins an older Pinocchio,
so it is not installed beside uvms; with ``UVMS_PLACO_PYTHON`` set, its step is measured in its own environment
(``placo_step.py``, benchmarks/README.md).

    pip install -e ".[bench]"
    python benchmarks/bench_speed.py [--ik-targets 10000] [--starts 200]   # about 3 min with the defaults
    python benchmarks/bench_speed.py --only-run   # the `uvms run` row alone (before/after: PYTHONPATH=OLD_TREE)
"""

from __future__ import annotations

import argparse
import json
import logging
import subprocess
import sys
import time
import warnings
from pathlib import Path

import bench_clik
import bench_ik
import bench_set_based
import numpy as np

import uvms
from uvms.workspace import monte_carlo

ROOT = Path(uvms.__file__).resolve().parent.parent  # the checkout imported (PYTHONPATH=OLD_TREE: before/after)


def clik_rows() -> list[tuple[str, str, str, str]]:
    """The CLIK step rows: uvms, the numpy step and pink, as ratios to FK."""
    robot = uvms.load(uvms.model.example_robot_urdf("ur5"), base="floating")
    ratios = bench_clik.clik_step_ratios(robot, 2000)
    fk = ratios.pop("_reference_us")
    general = ratios["uvms CLIKSolver built per step (general, with diagnostics)"]
    prepared = ratios["uvms CLIKSolver.step (built once, with W, sigma_min read)"]
    loop = ratios["uvms CLIKSolver.step in a loop (built once, with W, sigma_min read; q moving)"]
    others = [f"numpy DLS {ratios['plain numpy DLS step']:.0f}x"]
    if "pink solve_ik step (daqp)" in ratios:
        others.append(f"pink {ratios['pink solve_ik step (daqp)']:.0f}x")
    others += [f"placo {ratio:.0f}x (its own env)" for label, ratio in ratios.items() if label.startswith("placo")]
    return [(f"prepared general CLIK step, UR5 + floating base (FK {fk:.2f} us)",
             f"{prepared:.0f}x (`CLIKSolver` built once; {general:.0f}x built per step)", ", ".join(others), "<= 25x"),
            ("general CLIK step in a loop (`solver.step(configuration, dt)`)", f"{loop:.0f}x", "", "<= 40x"),
            ("`CLIKSolver.step`, pose task, no W",
             f"{ratios['uvms CLIKSolver.step, pose task (built once, no W)']:.0f}x", "", "<= 12x")]


def set_based_rows(starts: int, repeat: int) -> list[tuple[str, str, str, str]]:
    """The set-based and QP hierarchy steps (solvers built once per start, as a controller keeps them), and pink's
    step with limits on the same tasks, interleaved with FK; the goals are ratios to pink's step."""
    logging.disable(logging.WARNING)  # pink logs every start outside a limit
    problem = bench_set_based.Problem()
    steppers = {"solver": bench_set_based.PreparedStepper(problem),
                "hqp": bench_set_based.PreparedStepper(problem, uvms.HQPSolver),
                "set_based": bench_set_based.ours(uvms.SetBasedSolver, problem)}
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            import pink  # noqa: F401 - only whether it is there
        steppers["pink"] = bench_set_based.PinkStepper(problem)
    except Exception as error:  # noqa: BLE001 - skipped with the reason
        print(f"pink skipped: {type(error).__name__}: {error}")
    times = bench_set_based.step_times(problem, steppers, problem.starts(starts), repeat)
    pink = times.get("pink")
    other = f"pink with limits {pink:.0f}x" if pink else "pink not installed"

    def of_pink(key: str) -> str:
        return f" = {times[key] / pink:.2f}x pink's step" if pink else ""

    return [("set-based step, BlueROV2 + Alpha 5 (limits, speeds, attitude, pose)",
             f"**{times['solver']:.0f}x**{of_pink('solver')} (`SetBasedSolver`, built once; "
             f"{times['set_based']:.0f}x built per step)", other, "<= 0.5x pink's step"),
            ("QP hierarchy step, the same levels", f"**{times['hqp']:.0f}x**{of_pink('hqp')} (`HQPSolver`, built once)",
             other, "<= 2x pink's step")]


#: Up to the loop's first step: the interpreter, ``import uvms.cli``, reading the scenario, the model, the initial
#: configuration (scipy.optimize) and the controller (the kernels' import); the issue's "import + load + build".
BUILD_ONLY = ("from uvms.scenario.build import build; from uvms.scenario.schema import read_scenario; import uvms.cli; "
              "build(read_scenario({path!r}, ['outputs.figures=false']))")


def run_row(repeat: int = 3) -> tuple[str, str, str, str]:
    """``uvms run hoang2011_w1`` with figures off, in fresh processes (median of ``repeat``): its wall time, the
    time up to the loop (a process that only builds the run) and the run's own time (build and loop)."""
    path = str(ROOT / "scenarios" / "hoang2011_w1.toml")
    command = [sys.executable, "-m", "uvms.cli", "run", path, "--out", "/tmp/uvms_bench_speed_run",
               "--set", "outputs.figures=false", "--quiet"]
    walls, builds, inside = [], [], []
    for _ in range(repeat):
        started = time.perf_counter()
        subprocess.run(command, cwd=ROOT, capture_output=True, check=True)
        walls.append(time.perf_counter() - started)
        metrics = json.loads(Path("/tmp/uvms_bench_speed_run/metrics.json").read_text())
        inside.append(f"{metrics['wall_time']:.2f}")  # the run's own clock: build and loop
        started = time.perf_counter()
        subprocess.run([sys.executable, "-c", BUILD_ONLY.format(path=path)], cwd=ROOT, check=True)
        builds.append(time.perf_counter() - started)
    return ("`uvms run hoang2011_w1`, figures off (9,500 RK4 steps)",
            f"{np.median(walls):.2f} s ({min(walls):.2f}-{max(walls):.2f}; import + load + build "
            f"{np.median(builds):.2f} s; {', '.join(inside)} s of build and loop)", "",
            "<= 1 s (import + load + build <= 0.5 s)")


def ik_rows(targets: int) -> list[tuple[str, str, str, str]]:
    """Pose IK on the UR5, limits on, 1e-10, random starts: uvms and roboticstoolbox's ik_LM."""
    case = bench_ik.cases(targets, 0)[0]
    fk = bench_ik.fk_time(case.robot)
    ours = bench_ik.run(case, "uvms", bench_ik.uvms_solver(case, "random"), fk)
    solve = bench_ik.rtb_solver(case, uvms.model.example_robot_urdf("ur5"))
    other = "roboticstoolbox not installed"
    if solve is not None:
        theirs = bench_ik.run(case, "rtb", solve, fk)
        other = f"roboticstoolbox ik_LM {theirs.success:.2f} % at {theirs.median * 1e3:.3f} ms"
    return [(f"pose IK, UR5, {targets:,} targets, limits on, 1e-10",
             f"{ours.success:.2f} % at {ours.median * 1e3:.3f} ms median ({ours.median / fk:.0f}x FK)",
             f"{other}; TRAC-IK (published, 1e-5) 99.6-100 %", ">= 99.9 %, <= 0.1 ms")]


def workspace_rows() -> list[tuple[str, str, str, str]]:
    """monte_carlo of both xiang2019 arms, 1 M samples each: volumes, then with dexterity."""
    robot = uvms.load("xiang2019")
    rows = []
    for dexterity, goal in ((False, "<= 1 s"), (True, "<= 3 s")):
        started = time.perf_counter()
        monte_carlo(robot, ["left_ee", "right_ee"], 1_000_000, dexterity=dexterity, progress=False)
        rows.append(("Monte Carlo workspace, both xiang2019 arms, 1 M "
                     f"samples each{' + dexterity' if dexterity else ''}",
                     f"{time.perf_counter() - started:.2f} s", "", goal))
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ik-targets", type=int, default=2000, help="UR5 IK targets (the issue's row: 10000)")
    parser.add_argument("--starts", type=int, default=200, help="set-based starts the step times are drawn from")
    parser.add_argument("--repeat", type=int, default=200, help="interleaved set-based timing rounds")
    parser.add_argument("--only-run", action="store_true", help="only the `uvms run hoang2011_w1` row (about 20 s)")
    options = parser.parse_args()
    began = time.perf_counter()
    rows = [run_row()] if options.only_run else [
        *clik_rows(), *set_based_rows(options.starts, options.repeat), run_row(), *ik_rows(options.ik_targets),
        *workspace_rows()]
    print(f"uvms {uvms.__version__}, numpy {np.__version__}; {time.perf_counter() - began:.0f} s\n")
    print("| row | uvms | beside it | goal |\n|---|---|---|---|")
    for row in rows:
        print("| " + " | ".join(row) + " |")


if __name__ == "__main__":
    main()
