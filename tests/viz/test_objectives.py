"""inequalities.png (uvms.viz.objectives): a title that is not cut off, every line of an objective named, the method
by its full name, the title above the first panel."""

from __future__ import annotations

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg

from uvms.scenario import run_scenario
from uvms.viz.objectives import ROW_STYLES, inequality_figure

from conftest import NO_FIGURES


def test_the_inequality_figure_names_its_rows_and_method_and_keeps_its_title(tmp_path):
    run = run_scenario("hoang2011_w1_set_based", out=tmp_path / "s", progress=False,
                       overrides=[*NO_FIGURES, "simulation.duration=2"])
    objectives = run.setup.inequalities.objectives
    name = "a_scenario_name_as_long_as_the_longest_shipped_one_x"
    figure = inequality_figure(run.simulation, objectives, name, label="set_based",
                               others={"hqp": run.simulation})
    panel = figure.axes[0]
    runs = [text.get_text() for text in panel.get_legend().get_texts()]
    assert runs == ["set-based task priority (iCAT)", "QP hierarchy"]
    (limits,) = objectives
    twin = next(axis for axis in figure.axes[1:] if axis.get_legend() is not None)
    rows = twin.get_legend()
    assert [text.get_text() for text in rows.get_texts()] == ["q1", "q2", "q3"] == list(limits.names)
    styles = [line.get_linestyle() for line in rows.get_lines()]
    assert len(set(styles)) == 3  # one style per row, the same in the plotted lines
    drawn = [line for line in panel.lines if len(line.get_xdata()) == len(run.simulation.t)]
    assert len(drawn) == 2 * 3 and [line.get_linestyle() for line in drawn[:3]] == styles
    assert ":" not in [style for style in ROW_STYLES]  # dotted is the valid set's bounds
    canvas = FigureCanvasAgg(figure)
    canvas.draw()
    renderer = canvas.get_renderer()
    title = figure._suptitle.get_window_extent(renderer)
    assert figure.bbox.x0 <= title.x0 and title.x1 <= figure.bbox.x1  # not cut off at the sides
    assert title.y0 >= panel.get_tightbbox(renderer).y1  # above the first panel
    assert name in figure.get_suptitle().replace("\n", " ")
    assert np.all(np.isfinite(drawn[0].get_ydata()))
