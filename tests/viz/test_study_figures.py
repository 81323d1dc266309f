"""The figures of a study (uvms.viz.study): three PNGs of the sizes the table implies; none without a metric."""

from __future__ import annotations

import struct

from uvms.scenario.studies.sensitivity import summarize
from uvms.viz.labels import plain_text
from uvms.viz.study import save_study_figures, save_tune_history


def png_size(path) -> tuple[int, int]:
    data = path.read_bytes()
    assert data.startswith(b"\x89PNG")
    return struct.unpack(">II", data[16:24])


def test_the_three_figures_have_one_panel_per_metric_and_key(tmp_path, rng):
    keys, metrics = ["a", "b"], ["m1", "m2", "m3", "m4"]
    table = [{"trial": k, "a": float(a), "b": str(b), "m1": float(a), "m2": float(a**2), "m3": 1.0, "m4": float(b),
              "pass": bool(a > 0.5), "error": ""} for k, (a, b) in enumerate(zip(rng.uniform(0, 1, 30),
                                                                                rng.integers(0, 3, 30)))]
    summary = summarize(table, keys, metrics)
    paths = save_study_figures(table, keys, metrics, summary, tmp_path, title="t")
    assert [p.name for p in paths] == ["study_histograms.png", "study_scatter.png", "study_sensitivity.png"]
    dpi = 110  # uvms.io.outputs.save_figure
    assert png_size(paths[0]) == (round(3 * 3.6 * dpi), round((2 * 2.8 + 0.6) * dpi))  # 4 metrics: 3 columns, 2 lines
    assert png_size(paths[1]) == (round((2 * 2.8 + 0.8) * dpi), round((4 * 2.0 + 0.6) * dpi))  # metrics x keys
    assert png_size(paths[2])[0] == round(3 * 4.4 * dpi)  # m1, m2, m4 and pass (m3 is constant but listed)
    assert summary["sensitivity"]["m3"][0]["eta2"] is None  # a constant metric: no index


def test_no_figure_when_every_trial_failed(tmp_path):
    table = [{"trial": 0, "a": 1.0, "pass": False, "error": "ModelCheckError: x"}]
    assert save_study_figures(table, ["a"], [], summarize(table, ["a"], []), tmp_path) == []
    assert not list(tmp_path.iterdir())


def test_strings_from_a_scenario_are_drawn_as_plain_text(tmp_path):
    text = "$\\undefinedcmd{$"  # mathtext would fail on it: the figures draw it as it is
    table = [{"trial": k, "scenario.description": [text, "plain $5"][k % 2], "m1": float(k), "pass": k > 1,
              "error": ""} for k in range(4)]
    summary = summarize(table, ["scenario.description"], ["m1"])
    paths = save_study_figures(table, ["scenario.description"], ["m1"], summary, tmp_path, title="a $b$ {c")
    assert [p.name for p in paths] == ["study_histograms.png", "study_scatter.png", "study_sensitivity.png"]
    assert all(png_size(path)[0] > 100 for path in paths)
    rows = [{"trial": k, "model.args.l1": 0.1 * k, "value": float(k)} for k in range(3)]
    save_tune_history(rows, ["model.args.l1"], "max_position_error", "minimize", tmp_path / "tune.png", title=text)
    assert png_size(tmp_path / "tune.png") == (7 * 110, round((2 * 2.4 + 0.4) * 110))
    assert plain_text(text) == "\\$\\undefinedcmd{\\$" and plain_text("no dollar") == "no dollar"


def test_a_histograms_tick_labels_do_not_run_into_each_other(tmp_path, rng, monkeypatch):
    """A metric on a narrow range of small numbers (0.00045-0.00125, long labels) gets at most five x ticks whose
    labels do not overlap, and the trial counts integer ticks."""
    import numpy as np
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    import uvms.viz.study as study

    drawn = []
    monkeypatch.setattr(study.outputs, "save_figure", lambda figure, path: drawn.append(figure))
    values = rng.uniform(0.00045, 0.00125, 100)
    table = [{"trial": k, "m": float(v), "pass": True, "error": ""} for k, v in enumerate(values)]
    study.histograms(table, ["m"], "t", tmp_path / "h.png")
    figure = drawn[0]
    renderer = FigureCanvasAgg(figure).get_renderer()
    figure.draw(renderer)
    axis = figure.axes[0]
    boxes = [label.get_window_extent(renderer) for label in axis.get_xticklabels()
             if label.get_text() and axis.get_xlim()[0] <= label.get_position()[0] <= axis.get_xlim()[1]]
    assert 2 <= len(boxes) <= 6
    assert all(left.x1 < right.x0 for left, right in zip(boxes, boxes[1:]))  # each label ends before the next
    counts = [tick for tick in axis.get_yticks() if axis.get_ylim()[0] <= tick <= axis.get_ylim()[1]]
    np.testing.assert_array_equal(counts, np.round(counts))


def test_the_scatter_reads_each_metric_on_one_axis_per_row_and_each_key_on_one_per_column(tmp_path, rng,
                                                                                            monkeypatch):
    """A metric's panels share its y axis across the keys (its tick labels on the first column only), a key's share
    its x axis (labels on the last row only), and a panel carries at most six ticks a side."""
    import numpy as np
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    import uvms.viz.study as study

    drawn = []
    monkeypatch.setattr(study.outputs, "save_figure", lambda figure, path: drawn.append(figure))
    keys, metrics = ["a", "b", "c"], ["m1", "m2"]
    table = [{"trial": k, "a": float(a), "b": float(10 * a + 1), "c": ["x", "y"][k % 2], "m1": float(a ** 2),
              "m2": float(1e-4 * a), "pass": bool(a > 0.3), "error": ""} for k, a in enumerate(rng.uniform(0, 1, 30))]
    study.scatter(table, keys, metrics, "t", tmp_path / "s.png")
    figure = drawn[0]
    figure.draw(FigureCanvasAgg(figure).get_renderer())
    axes = np.array(figure.axes).reshape(len(metrics), len(keys))
    for i in range(len(metrics)):
        assert all(axes[i, 0].get_shared_y_axes().joined(axes[i, 0], axes[i, j]) for j in range(len(keys)))
        assert not axes[i, 0].get_shared_y_axes().joined(axes[0, 0], axes[1, 0]) or i == 0  # metrics apart
        for j in range(len(keys)):
            shown = [label for label in axes[i, j].get_yticklabels() if label.get_visible() and label.get_text()]
            assert bool(shown) == (j == 0), (i, j)
            inside = [tick for tick in axes[i, j].get_yticks() if axes[i, j].get_ylim()[0] <= tick
                      <= axes[i, j].get_ylim()[1]]
            assert 2 <= len(inside) <= 6, (i, j, inside)
    assert [label.get_text() for label in axes[-1, 2].get_xticklabels()] == ["x", "y"]  # a text key's values


def test_a_rankings_labels_never_run_over_their_bars(tmp_path, monkeypatch):
    """Each key's rho label lies after its bar, or inside the bar's end in white when the bar is long (eta^2 near
    1): drawn, no label's box crosses its bar's end, and every label stays inside the panel."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    import uvms.viz.study as study

    drawn = []
    monkeypatch.setattr(study.outputs, "save_figure", lambda figure, path: drawn.append(figure))
    sensitivity = {"m": [{"key": key, "eta2": eta2, "rho": 0.5, "p_value": 1e-193}
                         for key, eta2 in [("a", 0.97), ("b", 0.75), ("c", 0.61), ("d", 0.6), ("e", 0.3),
                                           ("f", 0.0)]]}
    study.ranking(sensitivity, ["m"], "t", tmp_path / "r.png")
    figure = drawn[0]
    renderer = FigureCanvasAgg(figure).get_renderer()
    figure.draw(renderer)
    axis = figure.axes[0]
    panel = axis.get_window_extent(renderer)
    bars = {round(bar.get_y() + 0.5 * bar.get_height()): bar.get_window_extent(renderer) for bar in axis.patches}
    texts = [text for text in axis.texts if text.get_text()]
    assert len(texts) == 6
    for text in texts:
        box, bar = text.get_window_extent(renderer), bars[round(text.get_position()[1])]
        inside = text.get_color() == "white"
        assert (bar.x0 <= box.x0 and box.x1 <= bar.x1) if inside else box.x0 >= bar.x1, text.get_text()
        assert panel.x0 <= box.x0 and box.x1 <= panel.x1, text.get_text()
    white = [text.get_color() == "white" for text in texts]  # bottom up: f, e, d, c, b, a
    assert white == [False, False, False, True, True, True]
