"""``uvms view``: the 3-D viewer of a model or a run folder (``--watch``: follow edits), or a headless picture."""

from __future__ import annotations

import argparse
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..errors import UVMSError
from ..robot import Robot
from .info import parse_assignments


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
    from ..scenario.record import named_model, replay_model

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
        from ..viz import drawing

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
    from ..viz.viewer import Viewer

    viewer = Viewer(robot, q, port=options.port)  # the camera framed on the robot at q
    try:
        print(f"viewer      {viewer.url}  (this machine only; Ctrl-C to stop)", flush=True)
        if result is not None:
            t, qs = result
            viewer.play(t, qs, speed=options.speed, progress=False if options.quiet else None)
        if options.watch:
            watch_viewer(options, viewer)
        from . import wait_for_interrupt  # looked up on uvms.cli at call time: tests replace it there

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
    from ..watch import WatchedFiles, watch

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
