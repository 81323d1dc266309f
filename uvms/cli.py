"""The ``uvms`` command line. Every error prints one line on stderr and exits with 2."""

from __future__ import annotations

import argparse
import os
import sys
import time
import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pinocchio as pin

from .errors import UVMSError
from .model.loader import load
from .robot import Robot

EXIT_USAGE = 2
EXIT_INTERRUPTED = 130  # 128 + SIGINT, as a shell reports a command stopped by Ctrl-C


class OneLineParser(argparse.ArgumentParser):
    """argparse that reports a usage error as one line (no usage dump) and exits 2."""

    def error(self, message: str) -> None:  # noqa: D102 - argparse API
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message} (see --help)\n")


def parse_assignments(items: Sequence[str] | None) -> dict[str, str]:
    """``["NAME=VALUE", ...]`` -> {NAME: VALUE}."""
    assignments: dict[str, str] = {}
    for item in items or ():
        name, sep, value = item.partition("=")
        if not sep or not name:
            raise UVMSError(f"--arg expects NAME=VALUE, got {item!r}")
        assignments[name] = value
    return assignments


def format_limits(lower: np.ndarray, upper: np.ndarray) -> str:
    """Limits of a joint as '[lo, hi]' with unbounded parts shown as '-'."""
    if lower.size != 1 or not (np.isfinite(lower[0]) and np.isfinite(upper[0])) or abs(lower[0]) > 1e30:
        return "-"
    return f"[{lower[0]:+.4f}, {upper[0]:+.4f}]"


def describe(robot: Robot) -> str:
    """The text of ``uvms info``: joints, DOF split, why the base is what it is, frames, mass, end-effector poses."""
    lines = [
        f"model       {robot.name}  ({robot.source})",
        f"base        {robot.base_type}: vehicle DOF {robot.n_vehicle}, arm DOF {robot.n_arm} "
        f"(nq {robot.nq}, nv {robot.nv})",
        f"base rule   {robot.base_reason}",
        f"total mass  {robot.total_mass:.3f} kg",
        "joints",
        f"  {'name':<24} {'type':<27} {'nq':>2} {'nv':>2}  limits [rad or m]",
    ]
    for joint in robot.joints:
        role = "vehicle" if joint.is_vehicle else "arm"
        kind = joint.kind.removeprefix("JointModel") + f" ({role})"
        lines.append(f"  {joint.name:<24} {kind:<27} {joint.nq:>2} {joint.nv:>2}  {format_limits(joint.lower, joint.upper)}")
    body_frames = [f.name for f in robot.model.frames if f.type == pin.FrameType.BODY]
    lines.append(f"frames      {', '.join(body_frames)}")
    q = robot.neutral()
    lines.append("end effectors at the neutral configuration (world frame, m / rad)")
    for frame in robot.ee_frames:
        pose = robot.fk(q, frame)
        rpy = pin.rpy.matrixToRpy(pose.rotation)
        lines.append(f"  {frame:<22} xyz {np.array2string(pose.translation, precision=4, suppress_small=True)}"
                     f"  rpy {np.array2string(rpy, precision=4, suppress_small=True)}")
    lines.append("checks      passed (unit axes, finite numbers, positive masses, inertias and geometry sizes, one tree, "
                 "base)")
    return "\n".join(lines)


def command_info(options: argparse.Namespace) -> int:
    """``uvms info MODEL``: load the model (running its checks) and describe it."""
    robot = load(options.model, base=options.base, args=parse_assignments(options.arg), ee=options.ee or None)
    print(describe(robot))
    return 0


def command_run(options: argparse.Namespace) -> int:
    """``uvms run SCENARIO``: run a scenario and write metrics, trajectory and figures (``--watch``: rerun on edits)."""
    from .scenario import run  # the scenario layer pulls in scipy and matplotlib
    from .scenario.verdict import verdict_line

    if options.watch:
        return watch_job(options, run_output_folder(options), scenario=scenario_file(options.scenario))
    overrides = [*(options.set or ()), *(["outputs.bag=true"] if options.bag else [])]
    result = run(options.scenario, out=options.out, overrides=overrides, progress=False if options.quiet else None)
    folder = result.files[0].parent
    metrics = result.metrics
    print(f"scenario    {metrics['scenario']}  ({metrics['steps']} steps, {metrics['wall_time']:.1f} s)")
    for key in ("max_position_error", "final_position_error", "max_orientation_error", "max_joint_limit_violation",
                "vehicle_travel", "vehicle_yaw_range", "arm_travel"):
        print(f"  {key:<27} {metrics[key]:.3e}")
    print(f"verdict     {verdict_line(metrics['verdict'])}")
    print(f"outputs     {folder}/ ({', '.join(path.name for path in result.files)})")
    if "bag" in metrics:
        counts = ", ".join(f"{topic} {count}" for topic, count in metrics["bag"]["topics"].items())
        print(f"bag         {folder / 'bag'}/ ({counts}); replay: ros2 bag play {folder / 'bag'}")
        for item, reason in metrics["bag"]["skipped"].items():
            print(f"uvms: note: bag without {item}: {reason}", file=sys.stderr)
    for warning in metrics["verdict"]["warnings"]:  # said on the terminal, not only in metrics.json
        print(f"uvms: warning: {metrics['scenario']}: {warning}", file=sys.stderr)
    return 0


def command_sweep(options: argparse.Namespace) -> int:
    """``uvms sweep SCENARIO --grid KEY=START:STOP:N ...``: run a grid of overrides, write sweep.csv and sweep.png."""
    from .scenario.sweep import sweep  # joblib, and dask only with --backend dask

    result = sweep(options.scenario, options.grid or (), jobs=options.jobs, backend=options.backend,
                   scheduler=options.scheduler, out=options.out, progress=False if options.quiet else None)
    print(result.text())
    folder = result.files[0].parent
    print(f"outputs     {folder}/ ({', '.join(path.name for path in result.files)}, point_*/)")
    if result.failed:
        first = result.failed[0]
        raise UVMSError(f"{len(result.failed)} of {len(result.rows)} sweep points failed (error column of "
                        f"{result.files[0]}); point {first['point']}: {first['error']}")
    return 0


def parse_figure_counts(text: str | None, samples: int) -> list[int]:
    """``"10000,50000,100000"`` -> [10000, 50000, 100000], each in [1, samples]."""
    if not text:
        return []
    try:
        counts = [int(item) for item in text.split(",") if item.strip()]
    except ValueError:
        counts = []
    if not counts or any(not 1 <= count <= samples for count in counts):
        raise UVMSError(f"--figures expects comma-separated sample counts in [1, {samples}] (-n), got {text!r}")
    return counts


def scenario_file(scenario: str) -> Path:
    """The file of a ``SCENARIO`` argument: a ``.toml`` path or a shipped scenario name (``hoang2011_w1``)."""
    from .scenario.resources import resolve_scenario_path

    return resolve_scenario_path(scenario)


def run_output_folder(options: argparse.Namespace) -> Path:
    """Where ``uvms run`` writes: ``--out``, else ``out/<scenario name>`` (the file stem if it cannot be read)."""
    if options.out:
        return Path(options.out)
    from .scenario import read_scenario

    try:
        return Path("out") / read_scenario(options.scenario, options.set or ())["scenario"]["name"]
    except UVMSError:
        return Path("out") / Path(options.scenario).stem


def watch_job(options: argparse.Namespace, out: Path, scenario: Path | None = None, model: str | None = None) -> int:
    """Run the command once, then again on every change of its scenario, model and model files (``--watch``).

    Each run is a child process writing into ``out`` (fixed for the session); one line per run compares its
    headline metrics with the previous run's. Ctrl-C stops the run and the watching (exit 130).
    """
    from .watch import Rerun, WatchedFiles, without_watch

    argv = [*without_watch(options.argv), "--out", str(out), "--quiet"]
    print(f"watching {scenario or model} and the files of its model; Ctrl-C to stop")
    rerun = Rerun(argv, out, lambda: WatchedFiles.of(scenario=scenario, model=model, ignore=[out]),
                  say=lambda line: print(line, flush=True))
    rerun.loop()
    return 0


def command_workspace(options: argparse.Namespace) -> int:
    """``uvms workspace MODEL --ee FRAME ... -n N``: Monte Carlo workspace, volumes, dexterity, points and figures.

    The samples are streamed (memory bounded for any N); points.npz and the scatter figures hold the first
    `uvms.workspace.POINTS_KEPT` samples per frame, and metrics.json says how many were stored (points_stored)
    of how many sampled (points_sampled).
    """
    from . import outputs
    from .viz.reports import write_workspace_outputs
    from .workspace import OrientationGrid, monte_carlo, parse_sample_count

    samples = parse_sample_count(options.samples)
    if not 0.0 < options.convergence_tolerance < 1.0:
        raise UVMSError(f"--convergence-tolerance must be in (0, 1) (0.01: 1 %), got {options.convergence_tolerance}")
    robot = load(options.model, base=options.base, args=parse_assignments(options.arg))
    frames = options.ee or robot.ee_frames
    figure_counts = parse_figure_counts(options.figures, samples)
    if not 0.0 <= options.dexterous_threshold <= 1.0:
        raise UVMSError(f"--dexterous-threshold must be in [0, 1], got {options.dexterous_threshold}")
    grid = OrientationGrid(options.directions, options.roll_bins, options.approach) if options.dexterity else False
    out = Path(options.out or Path("out") / f"workspace_{robot.name}")
    if options.watch:
        return watch_job(options, out, model=options.model)
    with outputs.run_folder(out) as folder:  # taken first: a second writer of the folder is refused at once
        result = monte_carlo(robot, frames, samples, seed=options.seed, voxel=options.voxel,
                             progress=False if options.quiet else None, remove_hull=options.remove_hull,
                             dexterity=grid, dexterity_voxel=options.dexterity_voxel)
        written = write_workspace_outputs(robot, result, frames, figure_counts, options.dexterous_threshold, folder,
                                          tolerance=options.convergence_tolerance)
    for frame in frames:
        line = f"{frame:<12} volume {result.volume[frame]:.4f} m^3 ({result.voxel} m voxels)"
        if result.volume_outside_hull is not None:
            line += f", outside the hull {result.volume_outside_hull[frame]:.4f} m^3"
        print(line)
    if result.common_volume is not None:
        line = f"{'common':<12} volume {result.common_volume:.4f} m^3"
        if result.common_volume_outside_hull is not None:
            line += f", outside the hull {result.common_volume_outside_hull:.4f} m^3"
        print(line)
    convergence = result.volume_converged(options.convergence_tolerance)
    for frame, verdict in convergence.items():
        print(verdict.status(frame))
    for frame, dexterity in (result.dexterity or {}).items():
        summary = dexterity.summary(options.dexterous_threshold)
        print(f"{frame:<12} dexterity mean {summary['mean']:.4f}, max {summary['max']:.4f} "
              f"({result.orientation_grid.count} orientation cells, {dexterity.voxel} m voxels, "
              f"median {summary['median_samples_per_voxel']:.0f} samples/voxel); "
              f"dexterous (>= {options.dexterous_threshold}) {summary['dexterous_volume']:.4f} m^3")
    stored = min(result.stored(frame) for frame in frames)
    if stored < result.samples:
        print(f"points.npz and the scatter figures keep the first {stored} of the {result.samples} samples per frame "
              f"(volumes and dexterity use all)")
    print(f"{result.samples_per_second:,.0f} samples/s; outputs in {out}/ (metrics.json, points.npz, "
          f"{', '.join(written)})")
    for frame, verdict in convergence.items():  # said on the terminal, not only in metrics.json
        if verdict.warning(frame):
            print(f"uvms: warning: {verdict.warning(frame)}", file=sys.stderr)
    return 0


def view_configuration(robot: Robot, values: Sequence[float] | None) -> np.ndarray:
    """``--q`` values as q: nq numbers (Pinocchio's q), vehicle pose + arm (nv numbers: [x, y, yaw] or
    [x, y, z, roll, pitch, yaw], then the arm), or the arm alone (n_arm numbers); none: neutral."""
    if not values:
        return robot.neutral()
    values = np.asarray(values, dtype=float)
    if len(values) == robot.nq:
        return robot.check_configuration(values)
    if len(values) == robot.nv and robot.n_vehicle:
        return robot.configuration(base=values[: robot.n_vehicle], arm=values[robot.n_vehicle:])
    if len(values) == robot.n_arm:
        return robot.configuration(arm=values)
    pose = f"{robot.n_vehicle} ({' '.join(robot.base.pose_names)}) + " if robot.n_vehicle else ""
    raise UVMSError(f"--q takes {robot.nq} numbers (q), {pose}{robot.n_arm} (vehicle pose + arm) or "
                    f"{robot.n_arm} (arm joints) for {robot.name}; got {len(values)}")


def view_robot(options: argparse.Namespace) -> tuple[Robot, str | None]:
    """The model of ``uvms view`` and a one-line note on it (or None): with ``--result DIR``, the model the run
    folder records (a MODEL, ``--arg`` or ``--base`` given too must describe it; an older folder without a record:
    MODEL as given, and a note); else a model file/name or the model of a scenario ``.toml``."""
    from .scenario.record import named_model, replay_model

    if options.result:
        return replay_model(options.result, options.model, parse_assignments(options.arg), options.base)
    if options.model is None:
        raise UVMSError("uvms view needs the model: `uvms view MODEL`, or `uvms view --result DIR` of a run folder "
                        "(which records its model)")
    return named_model(options.model, parse_assignments(options.arg), options.base), None


def read_result(robot: Robot, folder: str) -> tuple[np.ndarray, np.ndarray]:
    """(t (N,), q (N, nq)) of a run folder's ``trajectory.npz``, checked against the model."""
    path = Path(folder) / "trajectory.npz"
    if not path.is_file():
        raise UVMSError(f"{str(path)!r} does not exist; --result takes a run folder written by `uvms run`")
    try:
        with np.load(path) as arrays:
            t, q = np.asarray(arrays["t"], dtype=float), np.asarray(arrays["q"], dtype=float)
    except (OSError, ValueError, KeyError) as exc:
        raise UVMSError(f"cannot read t and q from {str(path)!r}: {exc}") from None
    if q.ndim != 2 or q.shape[1] != robot.nq or len(t) != len(q) or len(q) == 0:
        raise UVMSError(f"{str(path)!r} holds q of shape {q.shape} and t of shape {t.shape}, but {robot.name} "
                        f"has nq = {robot.nq}: is this the run's model (and its --arg/--base)?")
    return t, q


def frame_indices(t: np.ndarray, count: int) -> np.ndarray:
    """At most ``count`` row indices evenly spaced in time, first and last included."""
    wanted = np.linspace(t[0], t[-1], max(min(count, len(t)), 1))
    return np.unique(np.clip(np.searchsorted(t, wanted), 0, len(t) - 1))


def wait_for_interrupt() -> None:
    """Keep the viewer's server alive until Ctrl-C."""
    import time

    while True:
        time.sleep(3600)


def command_view(options: argparse.Namespace) -> int:
    """``uvms view MODEL [--q ...]`` / ``uvms view MODEL --result DIR``: the 3-D viewer, or a headless picture."""
    if options.frames < 1 or not options.fps > 0:
        raise UVMSError(f"--frames must be >= 1 and --fps > 0, got {options.frames} and {options.fps}")
    robot, notice = view_robot(options)
    if notice:
        print(notice, flush=True)
    q = view_configuration(robot, options.q)
    result = read_result(robot, options.result) if options.result else None
    if options.headless:
        from .viz import drawing

        out = Path(options.headless)
        if result is None:
            if out.suffix.lower() in drawing.WRITERS:
                raise UVMSError(f"an animation ({out.suffix}) needs --result DIR; write a picture (.png) of one "
                                f"configuration instead")
            drawing.snapshot_figure(robot, [q], titles=[robot.name], path=out, ncols=1, panel_size=6.0)
        else:
            t, qs = result
            if out.suffix.lower() in drawing.WRITERS:
                rows = frame_indices(t, options.frames)
                drawing.animate(robot, qs[rows], out, fps=options.fps, times=t[rows], trail_frame=robot.ee_frames[0],
                                title=robot.name, progress=False if options.quiet else None)
            else:
                rows = frame_indices(t, 4)
                drawing.snapshot_figure(robot, qs[rows], titles=[f"t = {t[k]:.2f} s" for k in rows], path=out)
        print(f"wrote {out}")
        return 0
    from .viz.viewer import Viewer

    viewer = Viewer(robot, q, port=options.port)  # the camera framed on the robot at q
    try:
        print(f"viewer      {viewer.url}  (this machine only; Ctrl-C to stop)", flush=True)
        if result is not None:
            t, qs = result
            viewer.play(t, qs, speed=options.speed, progress=False if options.quiet else None)
        if options.watch:
            watch_viewer(options, viewer)
        wait_for_interrupt()
    except KeyboardInterrupt:
        pass
    finally:
        viewer.close()
    return 0


def watch_viewer(options: argparse.Namespace, viewer) -> None:
    """``uvms view ... --watch``: reload the model in place on every edit, replay ``--result`` when it is rerun.

    With ``uvms run SCENARIO --watch`` in another terminal, the viewer follows both the model and the run.
    """
    from .scenario.record import read_run_record
    from .watch import WatchedFiles, watch

    scenario = Path(options.model) if str(options.model).endswith(".toml") else None
    result = Path(options.result).resolve() if options.result else None

    def recorded() -> tuple | None:  # the model the result records (a rerun may change it)
        try:
            record = read_run_record(result) if result is not None else None
        except UVMSError:
            return None
        return None if record is None else (record.source, sorted(record.args.items()), record.base, record.ee)

    shown = [recorded()]

    def files() -> WatchedFiles:
        model = options.model or (shown[0][0] if shown[0] else None)  # no MODEL: the recorded model's files
        watched = WatchedFiles.of(scenario=scenario, model=None if scenario else model)
        if result is not None:
            watched.files |= {result / "trajectory.npz", result}
        return watched

    def changed(paths: list[Path]) -> None:
        try:
            robot, _ = view_robot(options)
            now = recorded()
            model_changed = now != shown[0] or any(path.name != "trajectory.npz" and path != result for path in paths)
            shown[0] = now
            if model_changed:
                viewer.reload(robot)
            print(f"{time.strftime('%H:%M:%S')} {', '.join(sorted({p.name for p in paths}))} changed: "
                  f"{'model reloaded' if model_changed else 'replaying the new run'}", flush=True)
            if result is not None and (result / "trajectory.npz").is_file():
                t, qs = read_result(robot, str(result))
                viewer.play(t, qs, speed=options.speed, progress=False)
        except UVMSError as exc:
            print(f"{time.strftime('%H:%M:%S')} {' '.join(str(exc).split())} (still showing the last good model)",
                  flush=True)

    while True:
        watch(files(), changed, once=True)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``uvms``."""
    parser = OneLineParser(prog="uvms", description="Kinematics of underwater vehicle-manipulator systems.")
    commands = parser.add_subparsers(dest="command", required=True, parser_class=OneLineParser)
    info = commands.add_parser("info", help="describe a model and run its checks")
    info.add_argument("model", help="a .urdf/.xacro file or a shipped model name (e.g. hoang2011)")
    info.add_argument("--base", choices=["floating", "planar", "fixed"], help="vehicle base (default: as in the file)")
    info.add_argument("--arg", action="append", metavar="NAME=VALUE", help="xacro argument (repeatable)")
    info.add_argument("--ee", action="append", metavar="FRAME", help="end-effector frame (repeatable)")
    info.set_defaults(handler=command_info)
    run = commands.add_parser("run", help="run a scenario (TOML): metrics.json, trajectory.csv/.npz, figures")
    run.add_argument("scenario", help="scenario file or shipped scenario name, e.g. hoang2011_w1 or my_run.toml")
    run.add_argument("--out", help="output folder (default: out/<scenario name>)")
    run.add_argument("--set", action="append", metavar="KEY=VALUE",
                     help="override a scenario key, e.g. solver.gain=2 or model.args.l1=0.6 (repeatable)")
    run.add_argument("--bag", action="store_true",
                     help="also write the run as a ROS 2 bag (OUT/bag, MCAP: /joint_states, /tf, /odom, desired pose, "
                          "/robot_description); same as --set outputs.bag=true")
    run.add_argument("--quiet", action="store_true", help="no progress bar")
    run.add_argument("--watch", action="store_true",
                     help="rerun whenever the scenario, the model or a file it includes changes (Ctrl-C stops)")
    run.set_defaults(handler=command_run)
    sweep = commands.add_parser("sweep", help="run a scenario on a grid of overrides: sweep.csv and sweep.png")
    sweep.add_argument("scenario", help="scenario file or shipped scenario name, e.g. santos2006_task_priority")
    sweep.add_argument("--grid", action="append", metavar="KEY=START:STOP:N",
                       help="sweep a scenario key over N values from START to STOP, or KEY=[a,b,...], e.g. "
                            "model.args.l1=1.5:2.5:5 (repeatable: the grid is the product)")
    sweep.add_argument("--jobs", type=int, default=1, help="parallel jobs (-1: all cores; dask: local workers)")
    sweep.add_argument("--backend", choices=["loky", "dask"], default="loky",
                       help="joblib backend: local processes, or a Dask cluster (needs uvms[dask])")
    sweep.add_argument("--scheduler", metavar="ADDRESS",
                       help="Dask scheduler, e.g. tcp://10.0.0.5:8786 (default: a local cluster of --jobs workers)")
    sweep.add_argument("--out", help="output folder (default: out/<scenario name>_sweep)")
    sweep.add_argument("--quiet", action="store_true", help="no progress bar")
    sweep.set_defaults(handler=command_sweep)
    workspace = commands.add_parser("workspace", help="Monte Carlo reachable workspace of end-effector frames")
    workspace.add_argument("model", help="a .urdf/.xacro file or a shipped model name")
    workspace.add_argument("--ee", action="append", metavar="FRAME", help="frame (repeatable; default: the end effectors)")
    workspace.add_argument("-n", "--samples", default="10000",
                           help="joint samples per frame, e.g. 100000 or 1e9 (streamed: memory does not grow with N)")
    workspace.add_argument("--seed", type=int, default=0, help="random seed")
    workspace.add_argument("--voxel", type=float, default=0.05, help="voxel edge for the volume [m]")
    workspace.add_argument("--base", choices=["floating", "planar", "fixed"], help="vehicle base (default: as in the file)")
    workspace.add_argument("--arg", action="append", metavar="NAME=VALUE", help="xacro argument (repeatable)")
    workspace.add_argument("--figures", metavar="N1,N2,...",
                           help="also draw the first N1, N2, ... samples, e.g. 10000,50000,100000 "
                                "(xiang2019 Fig. 4): workspace_<N>.png")
    workspace.add_argument("--remove-hull", action="store_true",
                           help="drop the points inside the vehicle link's box/cylinder/sphere (URDF collision, "
                                "else visual) and report volume_outside_hull")
    workspace.add_argument("--dexterity", action="store_true",
                           help="measure the fraction of orientation cells reached per voxel (slower FK)")
    workspace.add_argument("--dexterity-voxel", type=float, default=0.1, help="voxel edge for the dexterity [m]")
    workspace.add_argument("--directions", type=int, default=100, help="equal-area cells of the approach direction")
    workspace.add_argument("--roll-bins", type=int, default=18,
                           help="bins of the roll about the approach axis (1: approach direction only)")
    workspace.add_argument("--approach", choices=["x", "y", "z"], default="z",
                           help="frame axis taken as the approach direction")
    workspace.add_argument("--dexterous-threshold", type=float, default=0.9,
                           help="dexterity from which a voxel counts as dexterous workspace")
    workspace.add_argument("--convergence-tolerance", type=float, default=0.01,
                           help="a volume has converged when the last doubling of the samples changes it by at "
                                "most this fraction (default 0.01: 1 %%); else a warning suggests more samples")
    workspace.add_argument("--out", help="output folder (default: out/workspace_<model>)")
    workspace.add_argument("--quiet", action="store_true", help="no progress bar")
    workspace.add_argument("--watch", action="store_true",
                           help="rerun whenever the model or a file it includes changes (Ctrl-C stops)")
    workspace.set_defaults(handler=command_workspace)
    view = commands.add_parser("view", help="3-D viewer of a model or a run (needs uvms[viz]), or --headless OUT")
    view.add_argument("model", nargs="?",
                      help="a .urdf/.xacro file, a shipped model name, or a scenario .toml (its model); with "
                           "--result: not needed (the run folder records its model), and if given it must match")
    view.add_argument("--result", metavar="DIR",
                      help="play the trajectory.npz of a run folder (uvms run) on the model it records")
    view.add_argument("--base", choices=["floating", "planar", "fixed"], help="vehicle base (default: as in the file)")
    view.add_argument("--arg", action="append", metavar="NAME=VALUE", help="xacro argument (repeatable)")
    view.add_argument("--q", nargs="+", type=float, metavar="V",
                      help="configuration: nq numbers (q), vehicle pose + arm joints, or arm joints only")
    view.add_argument("--port", type=int, default=8080, help="first port tried on 127.0.0.1 (default 8080)")
    view.add_argument("--speed", type=float, default=1.0, help="simulated seconds per second of playback")
    view.add_argument("--headless", metavar="OUT",
                      help="no viewer: write OUT.png (snapshot) or OUT.gif/.mp4 (animation of --result) "
                           "with matplotlib")
    view.add_argument("--frames", type=int, default=100, help="--headless animation: at most this many frames")
    view.add_argument("--fps", type=float, default=20.0, help="--headless animation: frames per second")
    view.add_argument("--quiet", action="store_true", help="no progress bar")
    view.add_argument("--watch", action="store_true",
                      help="reload the model in place when its files change; replay --result when it is rerun")
    view.set_defaults(handler=command_view)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``uvms`` console script."""
    options = build_parser().parse_args(argv)
    options.argv = list(sys.argv[1:] if argv is None else argv)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            status = options.handler(options)
        for warning in caught:
            print(f"uvms: warning: {warning.message}", file=sys.stderr)
        return status
    except UVMSError as exc:
        print(f"uvms: error: {' '.join(str(exc).split())}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt as exc:  # Ctrl-C: one line saying what the output folder holds (outputs.run_folder)
        notes = getattr(exc, "__notes__", None)
        if getattr(options, "watch", False):
            notes = ["stopped watching; the output folder keeps the last complete run"]
        print(f"uvms: interrupted; {notes[-1]}" if notes else "uvms: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except Exception as exc:  # noqa: BLE001 - the CLI promises one line, never a traceback
        if os.environ.get("UVMS_DEBUG"):
            raise
        print(f"uvms: internal error: {type(exc).__name__}: {' '.join(str(exc).split())} "
              f"(set UVMS_DEBUG=1 for a traceback)", file=sys.stderr)
        return EXIT_USAGE


if __name__ == "__main__":
    sys.exit(main())
