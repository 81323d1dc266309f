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
