"""``uvms identify LOG --model MODEL``: the vehicle's hydrodynamic parameters identified from a log.

LOG is a rosbag2 folder (MCAP or sqlite3: :mod:`uvms.scenario.bags.reader`) or a CSV file
(:data:`uvms.dynamics.identification.data.CSV_COLUMNS`). Writes into the output folder (replaced as a whole):

- ``hydrodynamics.yaml``: the model's hydrodynamics with the vehicle's identified, in the form
  :func:`uvms.dynamics.hydro.uuv.load_hydrodynamics_yaml` reads (``uvms.dynamics.hydrodynamics_of(robot,
  PATH)``);
- ``identification.json``: every parameter with its prior, value, standard error and 95 % interval, what was
  held by its prior (a soft constraint, :mod:`uvms.dynamics.identification.fit`) and why, fit metrics and the options;
- ``prediction.png`` (held-out segment) and ``residuals.png`` (:mod:`uvms.viz.identification`).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .info import parse_assignments
from .run import say_replaced
from .terminal import say


def add_identify_parser(commands: argparse._SubParsersAction, add_package_path) -> None:
    """The ``identify`` subcommand's arguments."""
    from ..scenario.bags.writer import BODY_WRENCH_TOPIC, JOINT_STATES_TOPIC, ODOM_TOPIC

    parser = commands.add_parser("identify", help="identify the vehicle's hydrodynamic parameters from a log "
                                                  "(ROS 2 bag or CSV): hydrodynamics.yaml, identification.json")
    parser.add_argument("log", help="a rosbag2 folder (MCAP or sqlite3) or a .csv file (see docs: identification)")
    parser.add_argument("--model", required=True, help="the model (.urdf/.xacro or a shipped name) the log is of")
    parser.add_argument("--arg", action="append", metavar="NAME=VALUE", help="xacro argument (repeatable)")
    parser.add_argument("--prior", metavar="YAML", help="hydrodynamics YAML to start from (default: the model's)")
    parser.add_argument("--out", help="output folder (default: out/identify_<model>)")
    parser.add_argument("--added-mass", choices=["diagonal", "full"], default="diagonal",
                        help="identify the 6 diagonal entries of the added mass, or the full symmetric 6 x 6")
    parser.add_argument("--window", type=float, default=0.3,
                        help="Savitzky-Golay window [s] for the twist's derivative (short against the motion)")
    parser.add_argument("--polyorder", type=int, default=3, help="Savitzky-Golay polynomial order")
    parser.add_argument("--holdout", type=float, default=0.2,
                        help="fraction of the log at its end kept out of the fit for the prediction check")
    parser.add_argument("--max-relative-error", type=float, default=0.2,
                        help="a parameter whose standard error exceeds this fraction of its scale is held")
    parser.add_argument("--current", type=float, nargs=3, metavar=("X", "Y", "Z"),
                        help="constant current [m/s], world ENU (default: the prior's): known, or the search's start")
    parser.add_argument("--identify-current", action="store_true",
                        help="identify the constant current too (the vehicle must turn and change speed)")
    parser.add_argument("--odom-topic", default=ODOM_TOPIC, help="nav_msgs/Odometry topic")
    parser.add_argument("--joint-states-topic", default=JOINT_STATES_TOPIC, help="sensor_msgs/JointState topic")
    parser.add_argument("--wrench-topic", default=BODY_WRENCH_TOPIC, help="geometry_msgs/WrenchStamped topic")
    parser.add_argument("--thrust-topics", metavar="PATTERN",
                        help="read the wrench from one std_msgs/Float64 topic per thruster instead, {name} the "
                             "model's thruster name (e.g. /thrusters/{name}/thrust, as uvms run --bag writes)")
    parser.add_argument("--thrust-commands", action="store_true",
                        help="the thruster topics hold commands: the model's thrust limits and first-order lag apply")
    parser.add_argument("--quiet", action="store_true", help="print only the folder line")
    add_package_path(parser)
    parser.set_defaults(handler=command_identify)


def read_log(options: argparse.Namespace, robot):
    """The log of ``options.log``: a CSV by its suffix, else a rosbag2 recording (its wrench from the thruster
    topics of ``robot`` with ``--thrust-topics``)."""
    from ..dynamics.identification.data import read_log_csv
    from ..errors import IdentificationError
    from ..scenario.bags.reader import read_bag
    from ..scenario.bags.thrust_log import thrust_input

    if options.thrust_commands and not options.thrust_topics:
        raise IdentificationError("--thrust-commands says what the thruster topics hold: give --thrust-topics too")
    if Path(options.log).suffix.lower() == ".csv":
        if options.thrust_topics:
            raise IdentificationError("--thrust-topics reads a bag's thruster topics; a CSV log holds the body "
                                      "wrench (columns fx ... mz)")
        return read_log_csv(options.log)
    thrust = (thrust_input(robot, options.thrust_topics, commands=options.thrust_commands)
              if options.thrust_topics else None)
    return read_bag(options.log, odom_topic=options.odom_topic, joint_states_topic=options.joint_states_topic,
                    wrench_topic=options.wrench_topic, thrust=thrust, arm_joints=robot.arm_joint_names)


def command_identify(options: argparse.Namespace) -> int:
    """``uvms identify LOG --model MODEL [--out DIR]``: identify, then write the folder (module docstring)."""
    from ..dynamics.hydro.hydrodynamics import hydrodynamics_of
    from ..dynamics.hydro.writer import hydrodynamics_yaml_text
    from ..dynamics.identification.identify import identify
    from ..io import outputs
    from ..io.names import default_output_folder
    from ..model.loader import load
    from ..scenario.watch import WatchedFiles
    from ..viz.identification import identification_figures

    robot = load(options.model, args=parse_assignments(options.arg), package_path=options.package_path)
    out = Path(options.out or default_output_folder("identify", robot.name))  # a bad folder is said before the fit
    model_files = WatchedFiles.of(model=options.model)
    inputs = [options.log, *model_files.files, *([options.prior] if options.prior else [])]
    log = read_log(options, robot)
    prior = hydrodynamics_of(robot, options.prior)
    replacing = outputs.holds_run(out)
    with outputs.run_folder(out, inputs=inputs) as folder:  # refused (an input inside, a busy folder) before the fit
        result = identify(robot, log, hydro=prior, added_mass=options.added_mass, current=options.current,
                          identify_current=options.identify_current,
                          window=options.window, polyorder=options.polyorder, holdout=options.holdout,
                          max_relative_error=options.max_relative_error)
        comments = [f"identified by uvms identify from {log.source} (model {robot.source})",
                    f"link {result.link}; identification.json beside this file gives the intervals and what was held"]
        outputs.write_text(folder / "hydrodynamics.yaml", hydrodynamics_yaml_text(result.hydro, comments))
        outputs.write_json(folder / "identification.json", result.as_dict())
        identification_figures(result, folder)
    if not options.quiet:
        for line in summary_lines(result):
            say(line, sys.stdout)
    say_replaced(replacing, out)
    say(f"wrote       {out}/ (hydrodynamics.yaml, identification.json, figures)", sys.stdout)
    return 0


def summary_lines(result) -> list[str]:
    """One line per parameter: name, prior, value, 95 % interval, and why it was held by its prior."""
    lines = [f"{'parameter':<24} {'prior':>11} {'identified':>11}  95 % interval; held because"]
    for p in result.parameters:
        detail = "" if p.interval is None else f"[{p.interval[0]:.4g}, {p.interval[1]:.4g}] {p.unit}"
        held = "" if p.identified else f"held: {p.reason}"
        lines.append(f"{p.name:<24} {p.prior:>11.4g} {p.value:>11.4g}  {'; '.join(filter(None, (detail, held)))}")
    held_out = result.metrics.get("held_out")
    if held_out and held_out["fit_percent_identified"] is not None:
        fits = ", ".join(f"{axis} {value:.1f}" for axis, value in held_out["fit_percent_identified"].items())
        lines.append(f"held-out fit [%] ({held_out['duration_s']:.1f} s): {fits}")
    return lines

