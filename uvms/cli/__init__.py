"""The ``uvms`` command line. Every error prints one line on stderr and exits with 2.

One module per command group: :mod:`.info` (``uvms info``), :mod:`.run` (``uvms run``, ``uvms sweep``,
``--watch``), :mod:`.study` (``uvms study``, ``uvms tune``), :mod:`.workspace` (``uvms workspace``), :mod:`.view`
(``uvms view``), :mod:`.identify` (``uvms identify``); here the argument parser
and :func:`main`, the one place that turns an error into one line and an exit status.

Every line :func:`main` prints goes through :func:`.terminal.say`: control characters and bidirectional overrides
(from a scenario key, a file name...) are shown escaped, never sent to the terminal. SIGTERM and SIGHUP take
the path of Ctrl-C: the run folder is cleaned up and one line says what the output folder holds.
"""

from __future__ import annotations

import argparse
import contextlib
import errno
import gc
import os
import signal
import sys
import threading
import warnings
from collections.abc import Iterator, Sequence

from ..errors import UVMSError, UVMSWarning
from .identify import add_identify_parser, command_identify
from .info import command_info, describe, format_limits, parse_assignments
from .run import command_run, command_sweep, run_output_folder, scenario_file, watch_job
from .study import command_study, command_tune
from .terminal import printable, say
from .view import (
    command_view,
    frame_indices,
    read_result,
    view_configuration,
    view_robot,
    watch_viewer,
)
from .workspace import command_workspace, parse_figure_counts

__all__ = [
    "EXIT_INTERRUPTED", "EXIT_USAGE", "OneLineParser", "build_parser", "command_identify", "command_info",
    "command_run", "command_study", "command_sweep", "command_tune", "command_view", "command_workspace", "describe",
    "format_limits", "frame_indices", "main",
    "parse_assignments", "parse_figure_counts", "printable", "read_result", "run_output_folder", "scenario_file",
    "view_configuration", "view_robot", "watch_job", "watch_viewer",
]

EXIT_USAGE = 2
EXIT_INTERRUPTED = 130  # 128 + SIGINT, as a shell reports a command stopped by Ctrl-C
#: Signals that stop a command as Ctrl-C does (exit status 128 + the signal).
STOP_SIGNALS = tuple(getattr(signal, name) for name in ("SIGTERM", "SIGHUP") if hasattr(signal, name))


@contextlib.contextmanager
def stop_signals_interrupt() -> Iterator[list[int]]:
    """While running a command: SIGTERM/SIGHUP raise KeyboardInterrupt (the list receives the signal).

    A second signal of the same kind ends the process at once (default action). Only in the main thread, where
    Python handles signals; an ignored signal stays ignored (``nohup``); the previous handlers are restored after.
    """
    received: list[int] = []
    if threading.current_thread() is not threading.main_thread():
        yield received
        return

    def stop(signum: int, frame: object) -> None:
        received.append(signum)
        signal.signal(signum, signal.SIG_DFL)
        raise KeyboardInterrupt

    previous = {signum: signal.signal(signum, stop) for signum in STOP_SIGNALS
                if signal.getsignal(signum) is not signal.SIG_IGN}
    try:
        yield received
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)


class OneLineParser(argparse.ArgumentParser):
    """argparse that reports a usage error as one line (no usage dump) and exits 2."""

    def error(self, message: str) -> None:  # noqa: D102 - argparse API
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message} (see --help)\n")


def add_package_path(parser: argparse.ArgumentParser) -> None:
    """The options of every command that loads a model: ``--package-path DIR`` (repeatable,
    :mod:`uvms.model.packages`) and ``--strict`` (every uvms warning an error, :func:`main`)."""
    parser.add_argument("--package-path", action="append", default=[], metavar="DIR",
                        help="folder of ROS packages for $(find pkg) and package://pkg/ (a package, or a folder "
                             "searched for package.xml); repeatable, before ROS_PACKAGE_PATH and the model's workspace")
    parser.add_argument("--strict", action="store_true",
                        help="refuse what uvms would only warn about (a hydrodynamic block naming a link the model "
                             "does not have, a default thruster value, ...): the first warning is an error, exit 2")


def add_model_options(parser: argparse.ArgumentParser, ee_help: str) -> None:
    """``--base``, ``--arg``, ``--ee`` and ``--arm-joints`` on a command that loads a model (``uvms info``, ``view``,
    ``workspace``): what :func:`uvms.load` takes, as a scenario's ``[model]`` table gives it
    (:func:`.info.command_model`)."""
    parser.add_argument("--base", choices=["floating", "planar", "fixed"], help="vehicle base (default: "
                                                                                "as in the file)")
    parser.add_argument("--arg", action="append", metavar="NAME=VALUE", help="xacro argument (repeatable)")
    parser.add_argument("--ee", action="append", metavar="FRAME", help=ee_help)
    parser.add_argument("--arm-joints", action="append", metavar="J1,J2,...",
                        help="the joints that move besides the vehicle, every other one frozen (repeatable or "
                             "comma-separated; \"\": none; default: the rule of uvms info's joint classes), as a "
                             "scenario's [model] arm_joints")


def add_parallel_options(parser: argparse.ArgumentParser) -> None:
    """``--jobs``, ``--backend``, ``--scheduler`` and ``--insecure-scheduler`` of ``uvms sweep``, ``study`` and
    ``tune``."""
    parser.add_argument("--jobs", type=int, default=1, help="parallel jobs (-1: all cores; dask: local workers)")
    parser.add_argument("--backend", choices=["loky", "dask"], default="loky",
                        help="joblib backend: local processes, or a Dask cluster (needs uvms[dask])")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="Dask scheduler, e.g. tls://10.0.0.5:8786, with TLS credentials from Dask's config "
                             "distributed.comm.tls.* (env DASK_DISTRIBUTED__COMM__TLS__CA_FILE, ..._CLIENT__CERT, "
                             "..._CLIENT__KEY) (default: a local TLS cluster of --jobs workers, no dashboard)")
    parser.add_argument("--insecure-scheduler", action="store_true",
                        help="accept a --scheduler that is not tls:// (tcp://): anyone who can reach it can run any "
                             "code on its workers and, through the pickled results, in this uvms process")


def add_study_parser(commands) -> None:
    """``uvms study``: a Monte Carlo study of a scenario."""
    study = commands.add_parser("study", help="Monte Carlo study of a scenario: study.csv, summary.json, figures")
    study.add_argument("scenario", help="scenario file or shipped scenario name (its [study] table gives defaults)")
    # each flag is named as the [study] key it sets: samples, n, seed, method, set
    study.add_argument("--samples", action="append", metavar="KEY=DIST",
                       help="sample a scenario key: normal(mu, sigma), normal(mu, sigma, low, high), uniform(a, b), "
                            "loguniform(a, b), choice([...]); KEY[i] samples one element of a list key, e.g. "
                            "plant.current[1]=uniform(-0.3, 0.3) (repeatable; default: [study] samples)")
    study.add_argument("-n", "--n", type=int, metavar="N", help="number of trials (default: [study] n)")
    study.add_argument("--seed", type=int, help="the study's seed (default: [study] seed, else 0)")
    study.add_argument("--method", choices=["random", "lhs", "sobol"],
                       help="random (per-trial seeds), Latin hypercube or scrambled Sobol (default: [study] method)")
    study.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a key in every trial (repeatable)")
    add_parallel_options(study)
    study.add_argument("--out", help="study folder (default: out/<scenario name>_study); the same study there is "
                                     "resumed (finished trials skipped), another is refused")
    study.add_argument("--quiet", action="store_true", help="no progress bar")
    add_package_path(study)
    study.set_defaults(handler=command_study)


def add_tune_parser(commands) -> None:
    """``uvms tune``: tune scenario keys with Optuna."""
    tune = commands.add_parser("tune", help="tune scenario keys (gains...) with Optuna: best --set list, best.toml")
    tune.add_argument("scenario", help="scenario file or shipped scenario name")
    tune.add_argument("--param", action="append", metavar="KEY=LOW:HIGH[:log]",
                      help="a tuned key and its range, e.g. solver.gain=0.5:4:log (repeatable)")
    tune.add_argument("--objective", default="max_position_error",
                      help="a metric to minimise (max_position_error, final_position_error, rms_position_error, "
                           "max_orientation_error, max_vehicle_tilt, max_joint_limit_violation) or pass_rate to "
                           "maximise (default max_position_error)")
    tune.add_argument("--trials", type=int, default=20, help="Optuna trials (default 20)")
    tune.add_argument("--seed", type=int, default=0, help="seed of the TPE sampler")
    tune.add_argument("--samples", action="append", metavar="KEY=DIST",
                      help="robust tuning: every trial is a study over these disturbances (as uvms study)")
    tune.add_argument("--study-n", type=int, default=8, metavar="M",
                      help="trials of each study, its [study] n (with --samples; default 8)")
    tune.add_argument("--study-seed", type=int, default=0, help="seed of each study: the same disturbances each trial")
    tune.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a key in every run (repeatable)")
    add_parallel_options(tune)
    tune.add_argument("--out", help="output folder (default: out/<scenario name>_tune), replaced whole")
    add_package_path(tune)
    tune.set_defaults(handler=command_tune)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``uvms``."""
    parser = OneLineParser(prog="uvms", description="Kinematics of underwater vehicle-manipulator systems.")
    commands = parser.add_subparsers(dest="command", required=True, parser_class=OneLineParser)
    info = commands.add_parser("info", help="describe a model and run its checks")
    info.add_argument("model", help="a .urdf/.xacro file, a shipped model name (e.g. hoang2011) or a scenario .toml "
                                    "(its model)")
    add_model_options(info, "end-effector frame (repeatable)")
    info.add_argument("--hydrodynamics", metavar="YAML", help="show the hydrodynamics of this YAML file (e.g. what "
                                                               "uvms identify wrote) in place of the model's")
    add_package_path(info)
    info.set_defaults(handler=command_info)
    run = commands.add_parser("run", help="run a scenario (TOML): metrics.json, trajectory.csv/.npz, figures")
    run.add_argument("scenario", help="scenario file or shipped scenario name, e.g. hoang2011_w1 or my_run.toml")
    run.add_argument("--out", help="output folder (default: out/<scenario name>)")
    run.add_argument("--set", action="append", metavar="KEY=VALUE",
                     help="override a scenario key, e.g. solver.gain=2 or model.args.l1=0.6 (repeatable)")
    run.add_argument("--bag", action="store_true",
                     help="also write the run as a ROS 2 bag (OUT/bag, MCAP: /joint_states, /tf, /odom, desired pose, "
                          "/robot_description); same as --set outputs.bag=true")
    run.add_argument("--quiet", action="store_true",
                     help="print only the result line (verdict and folder); warnings still go to stderr")
    run.add_argument("--watch", action="store_true",
                     help="rerun whenever the scenario, the model or a file it includes changes (Ctrl-C stops)")
    add_package_path(run)
    run.set_defaults(handler=command_run)
    sweep = commands.add_parser("sweep", help="run a scenario on a grid of overrides: sweep.csv and sweep.png")
    sweep.add_argument("scenario", help="scenario file or shipped scenario name, e.g. santos2006_task_priority")
    sweep.add_argument("--grid", action="append", metavar="KEY=START:STOP:N",
                       help="sweep a scenario key over N values from START to STOP, or KEY=[a,b,...], e.g. "
                            "model.args.l1=1.5:2.5:5 (repeatable: the grid is the product)")
    add_parallel_options(sweep)
    sweep.add_argument("--out", help="output folder (default: out/<scenario name>_sweep)")
    sweep.add_argument("--quiet", action="store_true", help="no progress bar")
    add_package_path(sweep)
    sweep.set_defaults(handler=command_sweep)
    add_study_parser(commands)
    add_tune_parser(commands)
    workspace = commands.add_parser("workspace", help="Monte Carlo reachable workspace of end-effector frames")
    workspace.add_argument("model", help="a .urdf/.xacro file, a shipped model name or a scenario .toml (its model)")
    add_model_options(workspace, "frame (repeatable; default: the end effectors)")
    workspace.add_argument("-n", "--samples", default="10000",
                           help="joint samples per frame, e.g. 100000 or 1e9 (streamed: memory does not grow with N)")
    workspace.add_argument("--seed", type=int, default=0, help="random seed")
    workspace.add_argument("--voxel", type=float, default=0.05, help="voxel edge for the volume [m]")
    workspace.add_argument("--figures", metavar="N1,N2,...",
                           help="also draw the first N1, N2, ... samples, e.g. 10000,50000,100000 "
                                "(xiang2019 Fig. 4): workspace_<N>.png")
    workspace.add_argument("--remove-hull", action="store_true",
                           help="drop the points inside the solids of the links fixed to the vehicle (box, cylinder, "
                                "sphere, a mesh's convex hull; URDF collision, else visual) and report "
                                "volume_outside_hull")
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
    add_package_path(workspace)
    workspace.set_defaults(handler=command_workspace)
    view = commands.add_parser("view", help="3-D viewer of a model or a run (needs uvms[viz]), or --headless OUT")
    view.add_argument("model", nargs="?",
                      help="a .urdf/.xacro file, a shipped model name, or a scenario .toml (its model); with "
                           "--result: not needed (the run folder records its model), and if given it must match")
    view.add_argument("--result", metavar="DIR",
                      help="play the trajectory.npz of a run folder (uvms run) on the model it records")
    add_model_options(view, "end-effector frame drawn with a triad (repeatable; default: the model's rule, see uvms "
                            "info)")
    view.add_argument("--q", nargs="+", type=float, metavar="V",
                      help="configuration: nq numbers (q), vehicle pose + arm joints, or arm joints only")
    view.add_argument("--port", type=int, default=8080, help="first port tried on 127.0.0.1 (default 8080)")
    view.add_argument("--speed", type=float, default=1.0, help="simulated seconds per second of playback")
    view.add_argument("--headless", metavar="OUT",
                      help="no viewer: write OUT.png (snapshot of --q, else of a scenario's initial configuration, "
                           "else of the model's neutral one) or OUT.gif/.mp4 (animation of --result) with matplotlib")
    view.add_argument("--frames", type=int, default=100, help="--headless animation: at most this many frames")
    view.add_argument("--fps", type=float, default=20.0, help="--headless animation: frames per second")
    view.add_argument("--collision", action="store_true",
                      help="show the collision shapes (the <collision> geometry the collision objectives check); a "
                           "scenario's or a run's collision objectives have their closest pair marked anyway")
    view.add_argument("--quiet", action="store_true", help="no progress bar")
    view.add_argument("--watch", action="store_true",
                      help="reload the model in place when its files change; replay --result when it is rerun")
    add_package_path(view)
    view.set_defaults(handler=command_view)
    add_identify_parser(commands, add_package_path)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``uvms`` console script.

    Called as the program (``argv`` None: the console script, ``python -m uvms.cli``), the process ends with the
    command: the objects made by then are frozen out of the garbage collector (``gc.freeze``), so the
    interpreter's exit does not walk the ~10^5 objects of numba, scipy and the run (0.1-0.2 s of a 2 s run).
    """
    try:
        return _main(argv)
    finally:
        if argv is None:
            gc.freeze()


def _main(argv: Sequence[str] | None) -> int:
    """:func:`main` itself: parse, run the command, turn an error into one line and an exit status."""
    options = build_parser().parse_args(argv)
    options.argv = list(sys.argv[1:] if argv is None else argv)
    options.program = argv is None  # the process ends with the command
    with stop_signals_interrupt() as received:
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                if getattr(options, "strict", False):
                    warnings.simplefilter("error", UVMSWarning)
                status = options.handler(options)
            for message in dict.fromkeys(str(warning.message) for warning in caught):  # each text once
                say(f"uvms: warning: {message}")
            return status
        except KeyboardInterrupt as exc:
            return interrupted(exc, options, received)
        except Exception as exc:  # noqa: BLE001 - the CLI promises one line, never a traceback
            if received:  # a stop signal that surfaced as another error (e.g. from a worker it stopped)
                return interrupted(exc, options, received)
            if isinstance(exc, UVMSError):
                say(f"uvms: error: {' '.join(str(exc).split())}")
                return EXIT_USAGE
            if isinstance(exc, UVMSWarning):  # --strict
                say(f"uvms: error: {' '.join(str(exc).split())} (--strict: a warning is an error)")
                return EXIT_USAGE
            if os.environ.get("UVMS_DEBUG"):
                raise
            if isinstance(exc, OSError) and exc.errno in (errno.ENOSPC, errno.EDQUOT):
                where = os.path.dirname(os.path.abspath(exc.filename)) if exc.filename else "the output folder"
                say(f"uvms: error: no space left on the device holding {where!r} ({exc.strerror})")
                return EXIT_USAGE
            say(f"uvms: internal error: {type(exc).__name__}: {' '.join(str(exc).split())} "
                f"(set UVMS_DEBUG=1 for a traceback)")
            return EXIT_USAGE


def interrupted(exc: BaseException, options: argparse.Namespace, received: Sequence[int]) -> int:
    """Ctrl-C, SIGTERM or SIGHUP: one line saying what the output folder holds (the note of outputs.run_folder)."""
    notes = getattr(exc, "__notes__", None)
    if getattr(options, "watch", False):
        notes = ["stopped watching; the output folder keeps the last complete run"]
    what = f"terminated by {signal.Signals(received[0]).name}" if received else "interrupted"
    say(f"uvms: {what}; {notes[-1]}" if notes else f"uvms: {what}")
    return 128 + received[0] if received else EXIT_INTERRUPTED
