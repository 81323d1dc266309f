"""Running a scenario: the one simulation loop, the metrics, and the files of the run folder."""

from __future__ import annotations

import contextlib
import gc
import os
import time
import warnings
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..control.sequence import sequence_metrics
from ..errors import NumericalError, OutputFailedWarning, UVMSError
from ..io import outputs
from ..robot.limits import Limit
from ..sim.loop import simulate
from ..sim.result import SimulationResult
from ..trajectory.table import pose_function
from .actuated import actuated_metrics, simulate_actuation
from .build import build
from .controllers import Setup
from .inequalities import ObjectiveRecorder, inequality_metrics, inequality_warnings, vehicle_tilt
from .record import model_record
from .schema import read_scenario
from .spec import ScenarioSpec
from .verdict import run_verdict


@dataclass
class RunResult:
    """A scenario run: its simulation, metrics and the files written."""

    scenario: ScenarioSpec
    setup: Setup
    simulation: SimulationResult
    metrics: dict
    files: list[Path]
    plant_run: SimulationResult | None = None  # dynamic [plant] only: the same run (its plant series filled)

def compute_metrics(result: SimulationResult, setup: Setup, wall_time: float) -> dict:
    """The numbers of ``metrics.json``."""
    robot = result.robot
    arm = result.arm()
    violation = Limit.joint_positions(robot).excess(arm)  # (N, n_arm) [rad or m]
    metrics = {
        "max_position_error": float(result.position_error.max()),
        "max_orientation_error": float(result.orientation_error.max()),
        "final_position_error": float(result.position_error[-1]),
        "rms_position_error": float(np.sqrt(np.mean(result.position_error**2))),
        "max_joint_limit_violation": float(np.nan_to_num(violation, nan=0.0).max(initial=0.0)),
        "arm_travel": float(np.abs(np.diff(arm, axis=0)).sum()),
        "steps": int(len(result.t) - 1),
        "wall_time": float(wall_time),
        "initial_configuration": setup.q0.tolist(),
        "initial_residual": float(setup.initial_residual),
    }
    if result.sigma_min is not None:  # an actuated run's controller has no one inverse to report
        metrics.update(min_sigma_min=float(result.sigma_min.min()), max_damping=float(result.damping.max()))
    if robot.base_type != "fixed":
        vehicle = result.vehicle_pose()
        position = vehicle[:, :2] if robot.base_type == "planar" else vehicle[:, :3]
        yaw = vehicle[:, -1]  # unwrapped
        metrics["vehicle_travel"] = float(np.linalg.norm(np.diff(position, axis=0), axis=1).sum())
        metrics["vehicle_yaw_range"] = float(yaw.max() - yaw.min())
        if robot.base_type == "floating":
            metrics["max_vehicle_tilt"] = float(vehicle_tilt(vehicle).max())
    else:
        metrics["vehicle_travel"] = 0.0
        metrics["vehicle_yaw_range"] = 0.0
    if setup.plan is not None:
        metrics.update(sequence_metrics(robot, setup.plan, result.t, result.q))
    if setup.inequalities is not None:
        metrics.update(inequality_metrics(setup.inequalities, result.arrays()))
    return metrics


def run_scenario(
    scenario_path: str | os.PathLike | ScenarioSpec,
    out: str | os.PathLike | None = None,
    overrides: Sequence[str] = (),
    progress: bool | None = None,
    *,
    lock: bool = True,
    settle: bool = False,
) -> RunResult:
    """Run a scenario file and write ``metrics.json``, ``trajectory.csv``/``.npz`` and figures into ``out``.

    ``metrics.json`` also records the model the run used (``"model"``: source, xacro args, base, end effectors,
    :mod:`uvms.scenario.record`) and the verdict (``"verdict"``: inside the joint limits, task error within
    ``[outputs]`` position/orientation tolerance, :mod:`uvms.scenario.verdict`).

    With a dynamic ``[plant]`` (rigid or hydrodynamic) the joints are driven by the GJM
    controller of :mod:`uvms.control.gjm` through :func:`uvms.sim.loop.simulate` on the ``Plant``, and
    ``plant.npz`` (commands, torques, energy, momentum) and the figures of
    :func:`uvms.viz.plotting.gjm_figures` are added.

    The scenario is read, checked and built (model, initial configuration, step count) before anything is
    written; then every file goes into a temporary folder that replaces ``out`` as a whole at the end
    (:func:`uvms.io.outputs.run_folder`): ``out`` holds the previous complete run until the new one is complete.
    ``out`` is refused if it holds the scenario or the model (:func:`run_inputs`), or files uvms did not write.

    Args:
        scenario_path: the TOML file, the name of a shipped scenario (``"hoang2011_w1"``), or a scenario already
            read (:func:`~uvms.scenario.schema.read_scenario`: not read again; ``overrides`` must then be empty).
        out: output folder (default ``out/<scenario name>``).
        overrides: ``SECTION.KEY=VALUE`` strings.
        progress: progress bar (None: on a terminal only).
        lock: hold the lock of ``out`` (False only for a folder inside another run folder, as the points of
            :func:`uvms.scenario.studies.sweep.sweep`).
        settle: the process ends with this run (the ``uvms run`` program): the build (the modules it imports,
            numba's registries, the model) runs without garbage collection and what it made is then frozen out of
            the collector (:func:`settled_build`).

    Raises:
        ScenarioError: a bad scenario or override; StepCountError: no step or too many steps;
        NumericalError: the numerics overflowed; RunFolderBusy: another uvms process writes ``out``;
        RunFolderError: ``out`` holds an input or files uvms did not write.
    """
    if isinstance(scenario_path, ScenarioSpec):
        if overrides:
            raise UVMSError("run_scenario: a scenario already read takes no overrides; apply them when reading it "
                            "(read_scenario(path, overrides))")
        spec = scenario_path
    else:
        spec = read_scenario(scenario_path, overrides)
    name = spec.scenario.name
    out = Path(out) if out is not None else Path("out") / name
    started = time.perf_counter()
    with numerics_guard(name), settled_build(settle):
        setup = build(spec)
    inputs = run_inputs(spec.path, [spec.model.path], spec.named_files())
    with outputs.run_folder(out, lock=lock, inputs=inputs) as folder, numerics_guard(name):
        result = execute(spec, setup, folder, progress, started)
    result.files = [out / path.relative_to(folder) for path in result.files]
    return result


@contextlib.contextmanager
def settled_build(settle: bool) -> Iterator[None]:
    """With ``settle``, the collector paused while a run is built, then what was made frozen out of it (``gc.freeze``)
    and the collector resumed: its full collections would walk the ~10^5 objects of the modules a build imports (two
    of 0.01-0.03 s while numba and scipy load) and the loop's would walk them again. Only for a process that ends
    with the run (frozen garbage is never collected); the loop's garbage is collected as always."""
    if not settle:
        yield
        return
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        gc.freeze()
        if enabled:
            gc.enable()


def run_inputs(scenario_file: str | os.PathLike, models: Iterable[str], files: Iterable[str] = ()) -> list[Path]:
    """What a run reads, which its output folder must not hold: the scenario file, the files it names
    (:meth:`~uvms.scenario.spec.ScenarioSpec.named_files`: e.g. an identified hydrodynamics YAML in a previous
    output folder), and each model file (a path or a shipped name) with the files it includes and their folders
    (meshes, YAML beside the model)."""
    from .watch import WatchedFiles

    found = {Path(scenario_file).resolve(), *(Path(file).resolve() for file in files)}
    for model in models:
        watched = WatchedFiles.of(model=model)  # an unreadable model adds nothing: the run reports it
        found |= watched.files | watched.folders
    return sorted(found)


@contextlib.contextmanager
def numerics_guard(name: str) -> Iterator[None]:
    """Turn an arithmetic failure escaping from the numerics (overflow, singular matrix...) into a NumericalError."""
    try:
        yield
    except (ArithmeticError, np.linalg.LinAlgError) as exc:
        message = " ".join(str(exc).split())
        raise NumericalError(f"scenario {name!r}: the numerics failed ({type(exc).__name__}"
                             f"{': ' + message if message else ''}); a number of the scenario (gain, damping, "
                             f"weight, dt, a model dimension) is too large or too small for the solvers") from exc


def write_run_bag(folder: Path, setup: Setup, result: SimulationResult, metrics: dict) -> Path:
    """The run as a ROS 2 bag in ``folder/bag`` (``[outputs] bag``); its topics and counts go into the metrics."""
    from .bags.writer import write_bag  # rosbags only when a bag is asked for

    frame = setup.task.frame if setup.task is not None else None
    thrusters = setup.actuation.thrusters.names if setup.actuation is not None else ()
    bag = write_bag(folder / "bag", setup.robot, result, desired_frame=frame, lock=False, thrusters=thrusters)
    metrics["bag"] = {"topics": bag.topics, "skipped": bag.skipped}
    return bag.path


def run_figures(spec: ScenarioSpec, setup: Setup, result: SimulationResult, plant_run: SimulationResult | None,
                folder: Path, progress: bool | None) -> list[Path]:
    """The figures of a run in ``folder`` (``[outputs] figures``): the standard ones, and those of its plant,
    actuation, inequalities and phases."""
    from ..viz.plotting import scenario_figures  # matplotlib only when figures are asked for

    title = spec.scenario.name
    files = scenario_figures(result, setup.trajectory, folder, title=title)
    if setup.actuation is not None:
        from ..viz.actuated import actuated_figures

        files += actuated_figures(result, setup.actuation.thrusters, folder, title=title, fins=setup.actuation.fins)
    if setup.inequalities is not None and setup.inequalities.objectives:
        from ..viz.objectives import inequality_figure

        label = "mpc" if spec.controller.type == "mpc" else spec.solver.method
        inequality_figure(result, setup.inequalities.objectives, title, label=label, path=folder / "inequalities.png")
        files.append(folder / "inequalities.png")
    if plant_run is not None:
        from ..viz.plotting import gjm_figures

        files += gjm_figures(plant_run, folder, title=title)
    if setup.plan is not None:
        from ..viz.plotting import sequence_figures

        files += sequence_figures(result, setup.plan, folder, title=title, animation=spec.outputs.animation,
                                  progress=progress)
    return files


def optional_output(name: str, failed: dict[str, str], write: Callable[[], list[Path]]) -> list[Path]:
    """The files ``write`` writes, or none when it fails on a defect of uvms (not on bad input: a UVMSError, a
    MemoryError or Ctrl-C go on): the failure is recorded in ``failed`` and said as a :class:`OutputFailedWarning`,
    and the run keeps its data and its other files (no internal error loses a run)."""
    try:
        return write()
    except (UVMSError, MemoryError):
        raise
    except Exception as exc:  # noqa: BLE001 - a defect in drawing must not lose the run
        failed[name] = f"{type(exc).__name__}: {' '.join(str(exc).split())}"
        warnings.warn(f"the run's {name} could not be written ({failed[name]}); its data (trajectory, metrics) are "
                      f"complete. This is a defect of uvms: please report it with the scenario", OutputFailedWarning,
                      stacklevel=2)
        return []


def execute(spec: ScenarioSpec, setup: Setup, folder: Path, progress: bool | None, started: float) -> RunResult:
    """Simulate a built scenario and write its files into ``folder``."""
    simulation_section = spec.simulation
    plant_run: SimulationResult | None = None
    # the objectives' rows the controller's solve evaluated at a row's q are read, not evaluated again
    recorders = [] if setup.inequalities is None else \
        [ObjectiveRecorder(setup.robot, setup.inequalities, getattr(setup.controller, "objective_rows", None))]
    if setup.actuation is not None:
        result = simulate_actuation(setup.actuation, setup.task, setup.samples or setup.trajectory, setup.q0,
                                    setup.duration, spec.simulation, progress)
    elif setup.plant is not None:
        controller = setup.controller
        result = plant_run = simulate(setup.plant, controller, setup.q0, setup.duration, simulation_section.dt,
                                      control_dt=setup.control_dt, integrator=simulation_section.integrator,
                                      task=setup.task,
                                      desired=None if setup.task is None else lambda t: controller.reference(t).pose,
                                      progress=progress, recorders=recorders)
    else:
        # the controller's samples: the row's time is already there
        desired = pose_function(setup.samples or setup.trajectory)
        result = simulate(setup.robot, setup.controller, setup.q0, setup.duration, simulation_section.dt,
                          task=setup.task, desired=desired,
                          integrator=simulation_section.integrator, progress=progress, recorders=recorders)
    metrics = compute_metrics(result, setup, time.perf_counter() - started)
    metrics["scenario"] = spec.scenario.name
    metrics["model"] = model_record(spec, setup.robot)  # what `uvms view --result DIR` replays the run on
    if plant_run is not None:
        metrics.update(plant=spec.plant.type, gjm=spec.plant.gjm,
                       motor_feedforward=spec.plant.motor_feedforward, **plant_run.plant_metrics())
    if setup.actuation is not None:
        metrics.update(actuated_metrics(result, setup.actuation, spec))
    files = list(result.save(folder))  # with actuation.npz when the run is actuated
    if plant_run is not None:
        outputs.write_npz(folder / "plant.npz", **plant_run.plant_arrays())
        files.append(folder / "plant.npz")
    failed: dict[str, str] = {}  # the run's data are written: a figure or bag that fails does not lose them
    if spec.outputs.figures:
        files += optional_output("figures", failed, lambda: run_figures(spec, setup, result, plant_run, folder,
                                                                         progress))
    if spec.outputs.bag:
        files += optional_output("bag", failed, lambda: [write_run_bag(folder, setup, result, metrics)])
    if failed:
        metrics["outputs_failed"] = failed
    metrics["verdict"] = run_verdict(metrics, spec.outputs, inequality_warnings(metrics))
    outputs.write_json(folder / "metrics.json", metrics)
    files.append(folder / "metrics.json")
    return RunResult(scenario=spec, setup=setup, simulation=result, metrics=metrics, files=files,
                     plant_run=plant_run)
