"""``uvms.cli.main`` as the program (no argv: the console script, ``python -m uvms.cli``) and as a function."""

from __future__ import annotations

import sys

import uvms.cli
from uvms.cli import main


def test_the_program_freezes_its_objects_before_exit_and_a_call_with_argv_never(monkeypatch, capsys):
    frozen = []
    monkeypatch.setattr(uvms.cli.gc, "freeze", lambda: frozen.append(True))
    assert main(["info", "hoang2011"]) == 0  # a test, a notebook: the process goes on, its collector untouched
    assert frozen == []
    monkeypatch.setattr(sys, "argv", ["uvms", "info", "hoang2011"])
    assert main() == 0
    assert frozen == [True]  # the exit then skips walking numba's and scipy's objects
    monkeypatch.setattr(sys, "argv", ["uvms", "info", "no_such_model"])
    assert main() == 2  # an error too
    assert frozen == [True, True]
    assert "uvms: error" in capsys.readouterr().err


def test_uvms_run_as_the_program_builds_without_collections_then_freezes_and_a_call_never(monkeypatch, tmp_path):
    import uvms.scenario.runs as runs

    calls = []
    for name in ("disable", "enable", "freeze"):
        monkeypatch.setattr(runs.gc, name, lambda name=name: calls.append(name))
    monkeypatch.setattr(runs.gc, "isenabled", lambda: True)
    built = runs.build

    def build(spec):  # what the run's build sees of the collector
        calls.append("build")
        return built(spec)

    monkeypatch.setattr(runs, "build", build)
    arguments = ["run", "hoang2011_w1", "--quiet", "--set", "trajectory.duration=0.2",
                 "--set", "trajectory.accel_time=0.1", "--set", "outputs.figures=false"]
    assert main([*arguments, "--out", str(tmp_path / "call")]) == 0
    assert calls == ["build"]  # a test, a notebook: the collector untouched
    monkeypatch.setattr(sys, "argv", ["uvms", *arguments, "--out", str(tmp_path / "program")])
    assert main() == 0  # the build's objects frozen, the loop collected as always, all frozen again before exit
    assert calls == ["build", "disable", "build", "freeze", "enable", "freeze"]
