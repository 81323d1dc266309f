"""`uvms study` on the command line: the summary lines, resume, one-line errors (exit 2), failed trials."""

from __future__ import annotations

import json

from uvms.cli import main

from conftest import SCENARIOS

SCENARIO = str(SCENARIOS / "hoang2011_w1.toml")
ARGS = ["--samples", "model.args.l1=uniform(0.35, 0.5)",
        "--samples", "outputs.position_tolerance=loguniform(1e-10, 1e-9)",
        "-n", "4", "--seed", "5", "--set", "trajectory.duration=10", "--set", "trajectory.accel_time=2",
        "--quiet"]


def test_cli_study_prints_the_pass_rate_and_resumes(tmp_path, capsys):
    out = tmp_path / "s"
    assert main(["study", SCENARIO, *ARGS, "--out", str(out)]) == 0
    lines = capsys.readouterr().out.splitlines()
    summary = json.loads((out / "summary.json").read_text())
    rate = summary["pass_rate"]
    assert lines[0] == (f"pass rate   {rate['passed']}/4 = {rate['rate']:.1%} (95 % Wilson interval "
                        f"{rate['ci_low']:.1%} to {rate['ci_high']:.1%})")
    assert lines[1].startswith("max_position_error") and "sensitivity of pass (eta^2, noise floor 0.33)" in lines[-2]
    assert summary["spec"]["n"] == 4 and summary["spec"]["seed"] == 5 and summary["spec"]["method"] == "random"
    assert main(["study", SCENARIO, *ARGS, "--out", str(out)]) == 0
    assert capsys.readouterr().out.splitlines()[-1].endswith("; 4 trials were already done (resumed)")


def test_cli_study_errors_are_one_line(tmp_path, capsys):
    out = tmp_path / "s"
    assert main(["study", SCENARIO, "--samples", "solver.gain=normal(1)", "-n", "3", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("uvms: error: --samples solver.gain=normal(1): normal takes 2 or 4 finite numbers; valid "
                          "forms: normal(mu, sigma)") and len(err.splitlines()) == 1
    assert main(["study", SCENARIO, "-n", "3", "--out", str(out)]) == 2  # no --samples, no [study] table
    assert "a study needs at least one --samples" in capsys.readouterr().err and not out.exists()
    assert main(["study", SCENARIO, "--samples", "model.args.vehicle_mass=choice([120.0, -5.0])", "-n", "4",
                 "--seed", "1", "--set", "trajectory.duration=10", "--set", "trajectory.accel_time=2", "--out",
                 str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err[-1].startswith("uvms: error: 3 of 4 trials failed (error column of ") and "ModelCheckError" in err[-1]


def test_cli_tune_prints_the_best_set_list(tmp_path, capsys):
    import pytest

    pytest.importorskip("optuna")
    out = tmp_path / "t"
    assert main(["tune", SCENARIO, "--param", "solver.gain=0.2:2:log", "--trials", "3", "--set",
                 "trajectory.duration=10", "--set", "trajectory.accel_time=2", "--out", str(out)]) == 0
    lines = capsys.readouterr().out.splitlines()
    best = json.loads((out / "best.json").read_text())
    assert lines[0] == f"best        max_position_error = {best['value']:.6g} (trial {best['trial']} of 3)"
    assert lines[1] == f"--set       solver.gain={best['parameters']['solver.gain']!r}"
    assert 0.2 <= best["parameters"]["solver.gain"] <= 2
    assert main(["tune", SCENARIO, "--param", "solver.gain=2:1", "--out", str(out)]) == 2
    assert capsys.readouterr().err.startswith("uvms: error: --param expects KEY=LOW:HIGH")


def test_the_flags_are_named_as_the_study_keys_they_set(capsys, tmp_path):
    """--samples is [study] samples (KEY=DIST), -n is [study] n: the number of the old --samples N gets a hint."""
    out = tmp_path / "s"
    assert main(["study", SCENARIO, "--samples", "4", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "--samples expects KEY=DIST" in err and "the number of trials is -n N, [study] n" in err
    assert not out.exists()
