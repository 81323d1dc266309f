"""``uvms view``: the 3-D viewer of a model or a run folder (``--watch``: follow edits), or a headless picture."""

from __future__ import annotations

import argparse
import sys
import time
import warnings
import zipfile
import zlib
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..errors import UVMSError, ViewerInputError
from ..robot.robot import Robot
from .info import command_model, parse_assignments
from .terminal import say


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


def start_configuration(options: argparse.Namespace, robot: Robot) -> tuple[np.ndarray, str]:
    """The configuration (nq,) ``uvms view`` shows (the viewer, or ``--headless PNG``), and its title: ``--q`` when
    given, else the initial configuration of a scenario ``.toml`` (the one its run starts from), else the model's
    neutral one."""
    if options.q or not str(options.model).endswith(".toml"):
        return view_configuration(robot, options.q), robot.name
    from ..scenario.build import scenario_start
    from ..scenario.schema import read_scenario

    spec = read_scenario(options.model)
    return scenario_start(robot, spec)[1], f"{spec.name}: initial configuration ({robot.name})"


def view_robot(options: argparse.Namespace) -> tuple[Robot, str | None]:
    """The model of ``uvms view`` and a one-line note on it (or None): with ``--result DIR``, the model the run
    folder records (a MODEL, ``--arg`` or ``--base`` given too must describe it; an older folder without a record:
    MODEL as given, and a note); else a model file/name or the model of a scenario ``.toml``."""
    from ..scenario.record import replay_model

    if options.result:
        for given, option, what in ((options.ee, "--ee", "end effectors"),
                                    (options.arm_joints is not None, "--arm-joints", "arm joints")):
            if given:
                raise UVMSError(f"{option} is for a model; a run folder (--result) is drawn with the {what} it was "
                                f"run with")
        return replay_model(options.result, options.model, parse_assignments(options.arg), options.base,
                            options.package_path)
    if options.model is None:
        raise UVMSError("uvms view needs the model: `uvms view MODEL`, or `uvms view --result DIR` of a run folder "
                        "(which records its model)")
    return command_model(options), None


def recorded_collision_types(folder: str) -> list[str]:
    """The collision objective types (:func:`~uvms.tasks.objectives.collision_types`) a run folder's
    ``metrics.json`` reports (its ``inequalities[name]["type"]``), none when it has no metrics."""
    from ..model.resources import read_json
    from ..tasks.objectives import collision_types

    path = Path(folder) / "metrics.json"
    metrics = read_json(path, "run metrics", ViewerInputError) if path.is_file() else {}
    tables = metrics.get("inequalities") if isinstance(metrics, dict) else None
    kinds = [entry.get("type") for entry in (tables.values() if isinstance(tables, dict) else [])
             if isinstance(entry, dict)]
    return [kind for kind in collision_types() if kind in kinds]


def view_objectives(options: argparse.Namespace, robot: Robot) -> tuple[list, str | None]:
    """The collision objectives whose closest pair ``uvms view`` marks, and a one-line note (or None).

    A scenario ``.toml`` given: its ``self_collision`` and ``obstacle`` tables (with ``--result`` or
    ``--collision``). Else a ``--result`` folder whose metrics report collision objectives: their tables are not
    in the folder, so the model's own self-collision pairs with the default ``min`` are marked, and a note says
    to give the scenario (an obstacle cannot be rebuilt from the folder).
    """
    from ..tasks.objectives import collision_types, inequalities_from_table
    from ..tasks.objectives.collision import SelfCollision

    if str(options.model).endswith(".toml") and (options.result or options.collision):
        from ..scenario.schema import read_scenario

        tables = [table for table in read_scenario(options.model).inequalities if table.type in collision_types()]
        return [item for table in tables for item in inequalities_from_table(robot, table.table)], None
    kinds = recorded_collision_types(options.result) if options.result else []
    if not kinds:
        return [], None
    marked = SelfCollision(robot)
    return [marked], (f"note        the run's collision tables ({', '.join(kinds)}) are not in its folder: marking "
                      f"the closest of the model's self-collision pairs (min {marked.min} m); give the scenario to "
                      f"mark its own: uvms view SCENARIO.toml --result {options.result}")


#: The most rows of a ``trajectory.npz`` that ``uvms view --result`` reads: 1,000,000 (a run of ``uvms run`` has
#: at most ``uvms.numerics.integrate.MAX_STEPS`` + 1 = 200,001), 8 MB per coordinate of q.
MAX_RESULT_ROWS = 1_000_000
#: The errors of reading a zip and its .npy headers (a truncated, corrupt or foreign file).
READ_ERRORS = (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile, zlib.error, NotImplementedError,
               RuntimeError)


def npy_header(archive: zipfile.ZipFile, info: zipfile.ZipInfo) -> tuple[tuple[int, ...], np.dtype, int]:
    """(shape, dtype, bytes the .npy member should hold) of a member of an .npz, from its header only."""
    with archive.open(info) as member:
        version = np.lib.format.read_magic(member)
        if version not in ((1, 0), (2, 0)):
            raise ValueError(f"{info.filename} is .npy format {version[0]}.{version[1]}; uvms writes 1.0")
        read = np.lib.format.read_array_header_1_0 if version == (1, 0) else np.lib.format.read_array_header_2_0
        shape, _, dtype = read(member)
        return shape, dtype, member.tell() + int(np.prod(shape, dtype=object)) * dtype.itemsize


def check_trajectory(path: Path, nq: int) -> None:
    """Refuse a ``trajectory.npz`` before it is loaded, from its zip directory and .npy headers alone: members
    other than the series uvms writes (:data:`uvms.sim.result.SERIES`), t and q not float64 of shapes (N,) and
    (N, nq) with 1 <= N <= :data:`MAX_RESULT_ROWS`, or a member size that contradicts its header.

    Raises:
        ViewerInputError: what is wrong, and what a run folder of uvms holds.
    """
    from ..sim.result import SERIES

    where = f"{str(path)!r} (--result)"
    try:
        with zipfile.ZipFile(path) as archive:
            infos = archive.infolist()
            names = [info.filename for info in infos]
            foreign = [name for name in names if name.removesuffix(".npy") not in SERIES or not name.endswith(".npy")]
            if foreign or len(set(names)) != len(names) or not {"t.npy", "q.npy"} <= set(names):
                raise ViewerInputError(f"{where} holds {', '.join(sorted(set(names)))[:300] or 'nothing'}; a run "
                                       f"folder's trajectory.npz holds t.npy and q.npy, and only the series "
                                       f"{', '.join(SERIES)}")
            headers = {info.filename: (*npy_header(archive, info), info.file_size) for info in infos
                       if info.filename in ("t.npy", "q.npy")}
    except READ_ERRORS as exc:
        raise ViewerInputError(f"cannot read {where} as the .npz of a run: {' '.join(str(exc).split())}") from None
    (t_shape, t_dtype, t_bytes, t_size), (q_shape, q_dtype, q_bytes, q_size) = headers["t.npy"], headers["q.npy"]
    rows = t_shape[0] if len(t_shape) == 1 else -1
    if len(q_shape) == 2 and q_shape[1] != nq:
        raise ViewerInputError(f"{where} holds q of shape {q_shape}, but the model has nq = {nq}: is this the run's "
                               f"model (and its --arg/--base)?")
    if (t_dtype != np.float64 or q_dtype != np.float64 or not 1 <= rows <= MAX_RESULT_ROWS
            or q_shape != (rows, nq)):
        raise ViewerInputError(f"{where} holds t {t_dtype} {t_shape} and q {q_dtype} {q_shape}; a run holds t "
                               f"float64 (N,) and q float64 (N, nq = {nq}) with 1 <= N <= {MAX_RESULT_ROWS:,}")
    if (t_size, q_size) != (t_bytes, q_bytes):
        raise ViewerInputError(f"{where}: t.npy or q.npy is {t_size} or {q_size} bytes, but its header says "
                               f"{t_bytes} or {q_bytes}; the file is corrupt")


def read_result(robot: Robot, folder: str) -> tuple[np.ndarray, np.ndarray]:
    """(t (N,), q (N, nq)) of a run folder's ``trajectory.npz``, checked against the model before it is loaded
    (:func:`check_trajectory`)."""
    path = Path(folder) / "trajectory.npz"
    if not path.is_file():
        raise UVMSError(f"{str(path)!r} does not exist; --result takes a run folder written by `uvms run`")
    check_trajectory(path, robot.nq)
    try:
        with np.load(path, allow_pickle=False) as arrays:
            t, q = np.asarray(arrays["t"], dtype=float), np.asarray(arrays["q"], dtype=float)
    except READ_ERRORS as exc:
        raise ViewerInputError(f"cannot read t and q from {str(path)!r}: {exc}") from None
    if q.shape != (len(t), robot.nq) or len(q) == 0:  # the file changed since it was checked
        raise ViewerInputError(f"{str(path)!r} holds q of shape {q.shape} and t of shape {t.shape}, but "
                               f"{robot.name} has nq = {robot.nq}: is this the run's model (and its --arg/--base)?")
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


def headless_path(name: str) -> Path:
    """The file ``--headless NAME`` writes: NAME, with ``.png`` added when it has no suffix.

    Raises:
        UVMSError: a suffix that is neither a picture format matplotlib writes nor an animation (.gif, .mp4).
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from ..viz.drawing import WRITERS

    out = Path(name)
    if not out.suffix:
        return out.with_name(f"{out.name}.png")
    pictures = sorted(f".{suffix}" for suffix in FigureCanvasAgg(Figure()).get_supported_filetypes())
    if out.suffix.lower() not in {*pictures, *WRITERS}:
        raise UVMSError(f"--headless {name!r}: unknown suffix {out.suffix!r}; write a picture "
                        f"({', '.join(pictures)}; none: .png) or, with --result, an animation ({', '.join(WRITERS)})")
    return out


def command_view(options: argparse.Namespace) -> int:
    """``uvms view MODEL [--q ...]`` / ``uvms view MODEL --result DIR``: the 3-D viewer, or a headless picture."""
    from ..viz.viewer import check_port

    if options.frames < 1 or not options.fps > 0:
        raise UVMSError(f"--frames must be >= 1 and --fps > 0, got {options.frames} and {options.fps}")
    check_port(options.port)
    robot, notice = view_robot(options)
    if notice:
        say(notice, sys.stdout)
    q, title = start_configuration(options, robot)
    result = read_result(robot, options.result) if options.result else None
    objectives, note = view_objectives(options, robot)
    if note:
        say(note, sys.stdout)
    if options.headless:
        from ..viz import drawing
        from ..viz.collision_drawing import CollisionOverlay

        out = headless_path(options.headless)
        # the visual meshes unless the collision shapes are asked for (one kind of shape in a picture)
        overlay = CollisionOverlay(robot, options.collision, objectives, visual=not options.collision)
        if result is None:
            if out.suffix.lower() in drawing.WRITERS:
                raise UVMSError(f"an animation ({out.suffix}) needs --result DIR; write a picture (.png) of one "
                                f"configuration instead")
            drawing.snapshot_figure(robot, [q], titles=[title], path=out, ncols=1, panel_size=6.0, overlay=overlay)
        else:
            t, qs = result
            if out.suffix.lower() in drawing.WRITERS:
                rows = frame_indices(t, options.frames)
                drawing.animate(robot, qs[rows], out, fps=options.fps, times=t[rows], trail_frame=robot.ee_frames[0],
                                title=robot.name, progress=False if options.quiet else None, overlay=overlay)
            else:
                rows = frame_indices(t, 4)
                drawing.snapshot_figure(robot, qs[rows], titles=[f"t = {t[k]:.2f} s" for k in rows], path=out,
                                        overlay=overlay)
        say(f"wrote {out}", sys.stdout)
        return 0
    from ..viz.viewer import Viewer

    with warnings.catch_warnings(record=True) as caught:  # said now, not when the viewer stops (meshes left out)
        warnings.simplefilter("always")
        viewer = Viewer(robot, q, port=options.port, collision=options.collision)  # the camera framed on q
        viewer.mark_closest(objectives)
    for warning in caught:
        say(f"uvms: warning: {' '.join(str(warning.message).split())}")
    try:
        say(f"viewer      {viewer.url}  (this machine only; Ctrl-C to stop)", sys.stdout)
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
    from ..scenario.record import read_run_record
    from ..scenario.watch import WatchedFiles, watch

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
                viewer.reload(robot)  # drops the marks of the old model's objectives: built again on the new one
                viewer.mark_closest(view_objectives(options, robot)[0])
            say(f"{time.strftime('%H:%M:%S')} {', '.join(sorted({p.name for p in paths}))} changed: "
                f"{'model reloaded' if model_changed else 'replaying the new run'}", sys.stdout)
            if result is not None and (result / "trajectory.npz").is_file():
                t, qs = read_result(robot, str(result))
                viewer.play(t, qs, speed=options.speed, progress=False)
        except UVMSError as exc:
            say(f"{time.strftime('%H:%M:%S')} {' '.join(str(exc).split())} (still showing the last good model)",
                sys.stdout)

    while True:
        watch(files(), changed, once=True)
