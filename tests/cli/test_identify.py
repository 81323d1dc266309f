"""``uvms identify LOG --model MODEL --out DIR`` (uvms.cli.identify): the files it writes, their round trip, and
one clear line for a bad log with nothing written."""

from __future__ import annotations

import json
import os
import re
import shutil

import numpy as np
import pytest

from uvms.cli import main
from uvms.dynamics.hydro.hydrodynamics import hydrodynamics_of
from uvms.dynamics.identification.data import log_csv_text
from uvms.dynamics.thrusters.thrusters import thrusters_of
from uvms.io import outputs
from uvms.scenario.bags.writer import write_bag

from conftest import excitation, one_line, shipped


@pytest.fixture(scope="module")
def bag(tmp_path_factory):
    """The heave-pitch excitation (30 s at 50 Hz) as the bag ``uvms run --bag`` would write."""
    robot = shipped("bluerov2_alpha5")
    run, _ = excitation("heave_pitch")
    path = tmp_path_factory.mktemp("identify") / "bag"
    write_bag(path, robot, run, thrusters=thrusters_of(robot).names)
    return path


def test_identify_writes_the_yaml_the_json_and_the_figures(bag, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["identify", str(bag), "--model", "bluerov2_alpha5", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "added_mass[w]" in printed and "held: " in printed and f"wrote       {out}/" in printed
    assert sorted(p.name for p in out.iterdir()) == [".uvms-run.json", "hydrodynamics.yaml", "identification.json",
                                                     "prediction.png", "residuals.png"]
    report = json.loads((out / "identification.json").read_text())
    values = {p["name"]: p for p in report["parameters"]}
    assert not values["linear_damping[v]"]["identified"] and "linear_damping[v]" in report["held_at_prior"]
    assert values["added_mass[w]"]["identified"] and len(values["added_mass[w]"]["interval_95"]) == 2
    # round trip: the model loaded with the written YAML has the identified numbers
    robot = shipped("bluerov2_alpha5")
    loaded = hydrodynamics_of(robot, out / "hydrodynamics.yaml").links["base_link"]
    assert loaded.added_mass[2, 2] == values["added_mass[w]"]["value"]
    assert loaded.quadratic_damping[2] == values["quadratic_damping[w]"]["value"]
    assert loaded.volume == values["volume"]["value"]
    np.testing.assert_allclose(loaded.center_of_buoyancy[2] * loaded.volume, values["buoyancy_moment[z]"]["value"],
                               rtol=1e-12)
    assert loaded.linear_damping[1] == values["linear_damping[v]"]["value"]  # held by its prior
    prior = hydrodynamics_of(robot)
    for name in prior.links:  # the arm's links are written as the model has them
        if name != "base_link":
            np.testing.assert_array_equal(hydrodynamics_of(robot, out / "hydrodynamics.yaml").links[name].added_mass,
                                          prior.links[name].added_mass)


def test_identify_reads_a_csv_log_too(tmp_path, capsys):
    _, log = excitation("heave_pitch")
    path = tmp_path / "log.csv"
    path.write_text(log_csv_text(log))
    out = tmp_path / "out"
    assert main(["identify", str(path), "--model", "bluerov2_alpha5", "--out", str(out), "--quiet"]) == 0
    assert capsys.readouterr().out.count("\n") == 1
    assert json.loads((out / "identification.json").read_text())["metrics"]["log_samples"] == len(log.t)


def test_identify_reads_the_thruster_topics_instead_of_the_wrench(bag, tmp_path, capsys):
    """--thrust-topics: the wrench of the thrusts through the model's thrusters (the same fit as /body_wrench's)."""
    runs = {}
    for name, extra in (("wrench", []), ("thrusts", ["--thrust-topics", "/thrusters/{name}/thrust",
                                                      "--wrench-topic", "/absent"])):
        out = tmp_path / name
        assert main(["identify", str(bag), "--model", "bluerov2_alpha5", "--out", str(out), "--quiet", *extra]) == 0
        parameters = json.loads((out / "identification.json").read_text())["parameters"]
        runs[name] = {p["name"]: p["value"] for p in parameters}
    for parameter, value in runs["wrench"].items():
        assert runs["thrusts"][parameter] == pytest.approx(value, rel=1e-6, abs=1e-9)


def test_identify_current_reports_and_writes_the_current(bag, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["identify", str(bag), "--model", "bluerov2_alpha5", "--out", str(out), "--identify-current"]) == 0
    assert "current[x]" in capsys.readouterr().out
    values = {p["name"]: p["value"] for p in json.loads((out / "identification.json").read_text())["parameters"]}
    written = hydrodynamics_of(shipped("bluerov2_alpha5"), out / "hydrodynamics.yaml").current
    np.testing.assert_array_equal(written, [values["current[x]"], values["current[y]"], values["current[z]"]])
    np.testing.assert_allclose(written, 0.0, atol=1e-3)  # the log was simulated in still water


@pytest.mark.parametrize("damage, message", [
    ("commands", "--thrust-commands says what the thruster topics hold: give --thrust-topics too"),
    ("csv thrust", "--thrust-topics reads a bag's thruster topics"),
    ("thrust topic", "the bag has no thrust of thruster_1 topic '/t/thruster_1'"),
    ("truncate", "cannot read the bag"),
    ("topic", "no wrench topic '/other'"),
    ("type", "holds sensor_msgs/msg/JointState"),
    ("nan", "non-finite value"),
])
def test_a_bad_log_gets_one_error_line_and_nothing_is_written(bag, tmp_path, capsys, damage, message):
    log = tmp_path / "log"
    shutil.copytree(bag, log)
    extra = []
    if damage == "truncate":
        storage = next(log.glob("*.mcap"))
        storage.write_bytes(storage.read_bytes()[:-4000])
    elif damage == "topic":
        extra = ["--wrench-topic", "/other"]
    elif damage == "type":
        extra = ["--odom-topic", "/joint_states"]
    elif damage == "commands":
        extra = ["--thrust-commands"]
    elif damage == "thrust topic":
        extra = ["--thrust-topics", "/t/{name}"]
    elif damage == "csv thrust":
        _, clean = excitation("heave_pitch")
        log = tmp_path / "log.csv"
        log.write_text(log_csv_text(clean))
        extra = ["--thrust-topics", "/thrusters/{name}/thrust"]
    else:
        _, clean = excitation("heave_pitch")
        rows = log_csv_text(clean).splitlines()
        cells = rows[120].split(",")
        cells[9] = "nan"
        rows[120] = ",".join(cells)
        log = tmp_path / "log.csv"
        log.write_text("\n".join(rows) + "\n")
    out = tmp_path / "out"
    assert main(["identify", str(log), "--model", "bluerov2_alpha5", "--out", str(out), *extra]) == 2
    line = one_line(capsys)
    assert line.startswith("uvms: error: ") and message in line
    assert not out.exists()


def csv_log(path, row: int | None = None, column: int | None = None, value: str = "") -> str:
    """The heave-pitch log as a CSV at ``path``, one cell (or a whole column with row None) set to ``value``."""
    _, clean = excitation("heave_pitch")
    rows = log_csv_text(clean).splitlines()
    if column is not None:
        for k in ([row] if row is not None else range(1, len(rows))):
            cells = rows[k].split(",")
            cells[column] = value
            rows[k] = ",".join(cells)
    path.write_text("\n".join(rows) + "\n")
    return str(path)


@pytest.mark.parametrize("cell, extra, message", [
    ((6, 8, "1e200"), [], (r"the linear velocity of sample 5 \(t = 0.1 s\) is 1e\+200; a log's linear velocity "
                           r"must be within \+-100")),
    ((None, 20, "1e300"), [], (r"the joint position of sample 0 .* is 1e\+300; a log's joint position must be "
                               r"within \+-1000")),
    ((2, 20, "100"), [], r"joint alpha_axis_e is at 100 in sample 1 \(t = 0.02 s\), outside its limits \[0, 6.3\]"),
    (None, ["--window", "1e308"], r"the smoothing window must be in \(0, 24\] s \(the log's duration\), got 1e\+308"),
    (None, ["--current", "1e308", "0", "0"], r"the current must be finite and at most 10 m/s"),
])
def test_numbers_out_of_range_get_one_error_line(tmp_path, capsys, cell, extra, message):
    """Before: LinAlgError, OverflowError, or a joint at 1e300 rad accepted and 43 % more added mass written."""
    log = csv_log(tmp_path / "log.csv", *(cell or ()))
    out = tmp_path / "out"
    assert main(["identify", log, "--model", "bluerov2_alpha5", "--out", str(out), *extra]) == 2
    line = one_line(capsys)
    assert line.startswith("uvms: error: ") and re.search(message, line), line
    assert not out.exists()


def test_a_line_break_in_the_logs_name_stays_in_its_comment(tmp_path, capsys):
    """The log's name is written on the comment line of hydrodynamics.yaml; a line break would start a YAML line."""
    log = csv_log(tmp_path / "log\nx.csv")
    out = tmp_path / "out"
    assert main(["identify", log, "--model", "bluerov2_alpha5", "--out", str(out), "--quiet"]) == 0
    text = (out / "hydrodynamics.yaml").read_text()
    assert text.splitlines()[0].startswith("# identified by uvms identify from ") and "log\\nx.csv (model " in text
    identified = json.loads((out / "identification.json").read_text())["parameters"]
    written = hydrodynamics_of(shipped("bluerov2_alpha5"), out / "hydrodynamics.yaml").links["base_link"]
    assert written.added_mass[2, 2] == next(p["value"] for p in identified if p["name"] == "added_mass[w]")


def test_an_input_inside_the_output_is_refused_and_leaves_no_lock_behind(tmp_path, capsys):
    """identify RUN/sub/log.csv --out RUN/sub left .sub.uvms-lock in the run folder RUN, which then held a file uvms
    had not listed: every later run into RUN was refused."""
    run = tmp_path / "run"
    with outputs.run_folder(run) as folder:
        (folder / "sub").mkdir()
        csv_log(folder / "sub" / "log.csv")
    before = sorted(os.listdir(run))
    assert main(["identify", str(run / "sub" / "log.csv"), "--model", "bluerov2_alpha5", "--out",
                 str(run / "sub")]) == 2
    assert "an input of this run" in one_line(capsys)
    assert sorted(os.listdir(run)) == before
    with outputs.run_folder(run) as folder:  # the run folder is still uvms's to replace
        (folder / "again.txt").write_text("replaced")
    assert (run / "again.txt").exists()
