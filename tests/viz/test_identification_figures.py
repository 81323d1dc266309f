"""Figures of an identification (uvms.viz.identification): the held-out prediction and the residuals."""

from __future__ import annotations

import numpy as np
import pytest

from uvms.dynamics.identification.identify import identify
from uvms.errors import IdentificationError
from uvms.viz.identification import identification_figures, prediction_figure, residual_figure

from conftest import excitation, shipped


def test_the_figures_draw_the_results_series(tmp_path):
    _, log = excitation("heave_pitch")
    result = identify(shipped("bluerov2_alpha5"), log)
    figure = prediction_figure(result)
    heave = figure.axes[4]  # rows of (u, p), (v, q), (w, r)
    lines = {line.get_label().split(" (")[0]: line for line in heave.get_lines()}
    np.testing.assert_array_equal(lines["measured"].get_ydata(), result.prediction.measured[:, 2])
    np.testing.assert_array_equal(lines["identified"].get_ydata(), result.prediction.identified[:, 2])
    assert "fit" in lines["identified"].get_label()
    residual = residual_figure(result).axes[5].get_lines()[0]
    np.testing.assert_array_equal(residual.get_ydata(), result.residuals[:, 5])
    written = identification_figures(result, tmp_path)
    assert sorted(path.name for path in written) == ["prediction.png", "residuals.png"]
    assert all(path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for path in written)


def test_no_held_out_segment_no_prediction_figure(tmp_path):
    _, log = excitation("heave_pitch")
    result = identify(shipped("bluerov2_alpha5"), log, holdout=0.0)
    assert result.prediction is None and "held_out" not in result.metrics
    with pytest.raises(IdentificationError, match="no held-out segment"):
        prediction_figure(result)
    assert [path.name for path in identification_figures(result, tmp_path)] == ["residuals.png"]
