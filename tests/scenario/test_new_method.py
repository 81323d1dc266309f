"""What a new solver method costs: one class and one registry entry, and every scenario can run it.

The method below is the plainest CLIK, v = J^+ (xdot_d + K e) with numpy's pseudo-inverse, written as a user
would add one: a :class:`uvms.solvers.Solver` subclass and one line in :data:`uvms.solvers.SOLVERS`. Nothing in
``uvms/scenario`` or ``uvms/control`` names it, yet ``uvms run --set solver.method=...`` runs it, refuses the keys
it does not take, and tracks the hoang2011 circle as CLIK does (the same law: W = I, no damping).
"""

from __future__ import annotations

import numpy as np
import pytest

from uvms.cli import main
from uvms.robot.configuration import Configuration
from uvms.solvers import SOLVERS, Solver, SolverResult
from uvms.solvers.clik import stacked_tasks
from uvms.solvers.result import SolvedRows
from uvms.solvers.stack import stacked_terms

from conftest import assert_tracks_like_clik, run_beside_clik


class PseudoInverseCLIK(Solver):
    """v = J^+ (xdot_d + K e) (nv,), numpy's pinv; the test's new method."""

    name = "pinv_clik"

    def __init__(self, robot, tasks, *, gain: float = 1.0) -> None:
        self.robot, self.tasks, self.gain, self.free_floating = robot, stacked_tasks(tasks), float(gain), False

    def velocity(self, configuration: Configuration) -> SolverResult:
        jacobian, error, feedforward = stacked_terms(self._checked(configuration), self.tasks)  # (k, nv), (k,), (k,)
        command = feedforward + self.gain * error
        singular_values = np.linalg.svd(jacobian, compute_uv=False)
        return SolverResult(v=np.linalg.pinv(jacobian) @ command, sigma_min=float(singular_values.min()), damping=0.0,
                            levels=(SolvedRows(0, jacobian, command, error),))


@pytest.fixture
def registered(monkeypatch):
    monkeypatch.setitem(SOLVERS, PseudoInverseCLIK.name, PseudoInverseCLIK)


def test_a_registered_method_runs_a_scenario_like_clik(registered, tmp_path):
    clik, new = run_beside_clik(tmp_path, "solver.method=pinv_clik")  # CLIK without its null-space term
    assert_tracks_like_clik(new, clik, error=1e-14, rel=1e-12)


def test_a_key_the_new_method_does_not_take_is_refused_with_what_it_takes(registered, tmp_path, capsys):
    code = main(["run", "hoang2011_w1", "--out", str(tmp_path / "x"), "--set", "solver.method=pinv_clik", "--quiet"])
    err = capsys.readouterr().err
    assert code == 2 and "solver.weights is not used by solver.method = 'pinv_clik', which takes solver.gain" in err


def test_an_unregistered_method_is_refused_with_the_registered_ones(tmp_path, capsys):
    code = main(["run", "hoang2011_w1", "--out", str(tmp_path / "x"), "--set", "solver.method=pinv_clik", "--quiet"])
    err = capsys.readouterr().err
    assert code == 2 and all(repr(name) in err for name in SOLVERS)
