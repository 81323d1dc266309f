"""``uvms run`` and ``uvms sweep``: scenarios from the command line, and ``--watch`` (rerun on every edit)."""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from ..errors import UVMSError
from .terminal import say

if TYPE_CHECKING:
    from ..scenario.spec import ScenarioSpec

#: The metrics ``uvms run`` prints, those a run has (all are in metrics.json).
HEADLINE_METRICS = ("max_position_error", "final_position_error", "max_orientation_error", "max_joint_limit_violation",
                    "vehicle_travel", "vehicle_yaw_range", "arm_travel", "max_vehicle_tilt", "min_clearance",
                    "min_self_distance", "min_obstacle_distance", "min_manipulability", "max_joint_speed_ratio",
                    "max_thrust_ratio", "saturated_time_fraction",
                    "vehicle_position_error", "thruster_energy")


def command_run(options: argparse.Namespace) -> int:
    """``uvms run SCENARIO``: run a scenario and write metrics, trajectory and figures (``--watch``: rerun on edits)."""
    from ..io.outputs import holds_run
    from ..scenario import read_scenario, run_scenario  # the scenario layer pulls in scipy and matplotlib
    from ..scenario.verdict import verdict_line

    if options.watch:
        return watch_job(options, run_output_folder(options), scenario=scenario_file(options.scenario))
    spec = read_scenario(options.scenario, [*(options.set or ()), *(["outputs.bag=true"] if options.bag else [])])
    spec = with_package_path(spec, options.package_path)  # read once: a bad scenario is said here, before any run
    out = Path(options.out) if options.out else Path("out") / spec.name
    if not options.quiet:  # the first line, within a second: what runs and where it goes (the loop shows a bar)
        say(start_line(spec, out), sys.stdout)
    replacing = holds_run(out)
    result = run_scenario(spec, out=out, progress=False if options.quiet else None,
                          settle=getattr(options, "program", False))  # one run, then the process ends
    folder = result.files[0].parent
    metrics = result.metrics
    if options.quiet:  # the one result line; warnings and notes still go to stderr
        say(f"{metrics['scenario']}: {verdict_line(metrics['verdict'])} -> {folder}/{replaced_note(replacing)}",
            sys.stdout)
        say_run_warnings(metrics)
        return 0
    say(f"scenario    {metrics['scenario']}  ({metrics['steps']} steps, {metrics['wall_time']:.1f} s)", sys.stdout)
    for key in HEADLINE_METRICS:
        if key in metrics:  # e.g. the thrusters' only in an actuated run
            say(f"  {key:<27} {metrics[key]:.3e}", sys.stdout)
    if "inequalities" in metrics:
        enforced = "enforced" if metrics["inequalities_enforced"] else "monitored, not enforced"
        shares = ", ".join(f"{name} {entry['active_fraction']:.0%}" for name, entry in metrics["inequalities"].items()
                           if "active_fraction" in entry)
        say(f"inequalities {enforced}; active: {shares or 'none with rows'}", sys.stdout)
    if "mpc" in metrics and "solve_time_median" in metrics["mpc"]:
        mpc = metrics["mpc"]
        say(f"mpc         {mpc['solves']} solves: median {1e3 * mpc['solve_time_median']:.1f} ms, p99 "
            f"{1e3 * mpc['solve_time_p99']:.1f} ms, {mpc['iterations_mean']:.2g} iterations", sys.stdout)
    say(f"verdict     {verdict_line(metrics['verdict'])}", sys.stdout)
    say(f"outputs     {folder}/ ({', '.join(path.name for path in result.files)})", sys.stdout)
    say_replaced(replacing, folder)
    if "bag" in metrics:
        counts = ", ".join(f"{topic} {count}" for topic, count in metrics["bag"]["topics"].items())
        say(f"bag         {folder / 'bag'}/ ({counts}); replay: ros2 bag play {folder / 'bag'}", sys.stdout)
    say_run_warnings(metrics)
    return 0


def start_line(spec: ScenarioSpec, out: Path) -> str:
    """The first line of ``uvms run``: scenario, model, simulated time and steps, solver, plant, output folder."""
    duration = spec.duration
    steps = spec.step_count()  # a step count out of range is refused here, before the build
    plant = spec.plant.type + (" with thrusters" if spec.plant.thrusters else "")
    model = Path(spec.model.path)
    with contextlib.suppress(ValueError):  # a model below the current folder is shown from there
        model = model.relative_to(Path.cwd())
    controller = (f"MPC ({spec.controller.solver}, {spec.controller.horizon} x {spec.controller.node_dt:g} s)"
                  if spec.controller.type == "mpc" else f"solver {spec.solver.method}")
    return (f"run         {spec.name}: model {model}, {duration:g} s in {steps} "
            f"steps of {spec.simulation.dt:g} s, {controller}, {plant} plant -> {out}/")


def say_run_warnings(metrics: dict) -> None:
    """The notes and warnings of a run on stderr (said on the terminal, not only in metrics.json)."""
    for item, reason in metrics.get("bag", {}).get("skipped", {}).items():
        say(f"uvms: note: bag without {item}: {reason}")
    for warning in metrics["verdict"]["warnings"]:
        say(f"uvms: warning: {metrics['scenario']}: {warning}")


def replaced_note(replacing: bool) -> str:
    """" (replaced the previous run)" after an output folder that held one, else ""."""
    return " (replaced the previous run)" if replacing else ""


def say_replaced(replacing: bool, folder: Path) -> None:
    """One line when the run replaced a previous complete run in ``folder`` (its files are gone)."""
    if replacing:
        say(f"replaced    the previous run in {folder}/", sys.stdout)


def command_sweep(options: argparse.Namespace) -> int:
    """``uvms sweep SCENARIO --grid KEY=START:STOP:N ...``: run a grid of overrides, write sweep.csv and sweep.png."""
    from ..io.outputs import holds_run
    from ..scenario.studies.sweep import sweep  # joblib, and dask only with --backend dask

    replacing = holds_run(run_output_folder(options, "_sweep"))
    result = sweep(options.scenario, options.grid or (), jobs=options.jobs, backend=options.backend,
                   scheduler=options.scheduler, out=options.out, progress=False if options.quiet else None,
                   overrides=package_path_overrides(options), insecure_scheduler=options.insecure_scheduler)
    for line in result.text().splitlines():
        say(line, sys.stdout)
    folder = result.files[0].parent
    say(f"outputs     {folder}/ ({', '.join(path.name for path in result.files)}, point_*/)", sys.stdout)
    say_replaced(replacing, folder)
    if result.failed:
        first = result.failed[0]
        raise UVMSError(f"{len(result.failed)} of {len(result.rows)} sweep points failed (error column of "
                        f"{result.files[0]}); point {first['point']}: {first['error']}")
    return 0


def with_package_path(spec: ScenarioSpec, folders: list[str] | None) -> ScenarioSpec:
    """``spec`` with the folders of ``--package-path DIR ...`` (from the current folder) before its own
    ``model.package_path``: what :func:`package_path_overrides` sets, on a scenario already read."""
    if not folders:
        return spec
    given = tuple(str(Path(folder).resolve()) for folder in folders)
    return dataclasses.replace(spec, model=dataclasses.replace(spec.model,
                                                               package_path=given + tuple(spec.model.package_path)))


def package_path_overrides(options: argparse.Namespace) -> list[str]:
    """``--package-path DIR ...`` of ``uvms run``/``sweep`` as the override of ``model.package_path``: the folders
    given (from the current folder) before the scenario's own (from the scenario file's folder)."""
    if not options.package_path:
        return []
    from ..scenario import read_scenario

    own = list(read_scenario(options.scenario, getattr(options, "set", None) or ()).model.package_path)
    folders = [str(Path(folder).absolute()) for folder in options.package_path] + own
    return [f"model.package_path={json.dumps(folders, ensure_ascii=False)}"]  # a TOML array of basic strings


def scenario_file(scenario: str) -> Path:
    """The file of a ``SCENARIO`` argument: a ``.toml`` path or a shipped scenario name (``hoang2011_w1``)."""
    from ..scenario.resources import resolve_scenario_path

    return resolve_scenario_path(scenario)


def run_output_folder(options: argparse.Namespace, suffix: str = "") -> Path:
    """Where ``uvms run`` (``uvms sweep``: ``suffix`` "_sweep") writes: ``--out``, else ``out/<scenario name><suffix>``
    (the file stem if the scenario cannot be read)."""
    if options.out:
        return Path(options.out)
    from ..scenario import read_scenario

    try:
        name = read_scenario(options.scenario, getattr(options, "set", None) or ()).name
    except UVMSError:
        name = Path(options.scenario).stem
    return Path("out") / f"{name}{suffix}"


def watch_job(options: argparse.Namespace, out: Path, scenario: Path | None = None, model: str | None = None) -> int:
    """Run the command once, then again on every change of its scenario, model and model files (``--watch``).

    Each run is a child process writing into ``out`` (fixed for the session); one line per run compares its
    headline metrics with the previous run's. Ctrl-C stops the run and the watching (exit 130).
    """
    from ..scenario.watch import Rerun, WatchedFiles, without_watch

    argv = [*without_watch(options.argv), "--out", str(out), "--quiet"]
    say(f"watching {scenario or model} and the files of its model; Ctrl-C to stop", sys.stdout)
    rerun = Rerun(argv, out, lambda: WatchedFiles.of(scenario=scenario, model=model, ignore=[out]),
                  say=lambda line: say(line, sys.stdout))
    rerun.loop()
    return 0
