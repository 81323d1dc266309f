"""Workspace volume convergence (uvms.workspace.convergence): the change over the last doubling, the
suggested sample count, and what `uvms workspace` prints."""

from __future__ import annotations

import json

import numpy as np
import pytest

from uvms.cli import main
from uvms.workspace import monte_carlo, volume_convergence

from conftest import one_line, shipped


def test_volume_convergence_from_the_last_doubling():
    converged = volume_convergence([(250, 0.5), (500, 0.9), (1000, 0.995), (2000, 1.0)], tolerance=0.01)
    assert converged.converged and converged.change == pytest.approx(0.005)
    short = volume_convergence([(250, 0.2), (500, 0.4), (1000, 0.6), (2000, 0.8)], tolerance=0.01)
    assert not short.converged and short.change == pytest.approx(0.25)
    # growth per doubling 0.333 -> 0.25 (ratio 0.75): 0.25 * 0.75^k <= 0.01 after k = 12 doublings: beyond 10
    assert short.suggested_samples is None and "more than -n 2048000" in short.warning("ee")
    halving = volume_convergence([(1000, 0.6), (2000, 0.8), (4000, 0.9)], tolerance=0.01)
    # changes 0.25 then 0.111 (ratio 0.444): 0.111 * 0.444^k <= 0.01 after k = 3 doublings
    assert halving.suggested_samples == 4000 * 2**3
    assert np.isnan(volume_convergence([(10, 0.0)]).change)


def test_workspace_prints_whether_the_volume_has_converged(tmp_path, capsys):
    assert main(["workspace", "hoang2011", "-n", "20000", "--out", str(tmp_path / "few"), "--quiet"]) == 0
    captured = capsys.readouterr()
    assert "ee           volume NOT converged: +6.17 % over the last doubling (10000 -> 20000 samples; " \
           "tolerance 1 %)" in captured.out
    assert captured.err.startswith("uvms: warning: the ee volume has not converged") and "-n 160000" in captured.err
    metrics = json.loads((tmp_path / "few" / "metrics.json").read_text())
    assert metrics["volume_converged"]["ee"]["converged"] is False
    assert main(["workspace", "hoang2011", "-n", "200000", "--out", str(tmp_path / "many"), "--quiet"]) == 0
    captured = capsys.readouterr()
    assert "ee           volume converged: +0.65 %" in captured.out and captured.err == ""
    result = monte_carlo(shipped("hoang2011"), ["ee"], 200_000, progress=False)
    assert result.volume_converged(0.001)["ee"].converged is False  # a tighter tolerance: not yet
    assert main(["workspace", "hoang2011", "--convergence-tolerance", "0", "--out", str(tmp_path / "x")]) == 2
    assert "--convergence-tolerance must be in (0, 1)" in one_line(capsys)
