"""The figure of a run's inequality objectives: each objective's value against its valid set, and its activation.

One panel per objective row group (a joint-limits objective draws every joint it holds, normalized to its
range), the valid set's bounds dotted, the activation band shaded, the activation on a second axis. Runs of
the same scenario with other methods (``others``) are overlaid, so "with and without the inequalities" is one
picture (``uvms run`` writes ``inequalities.png``; notebooks/set_based.ipynb overlays clik, set_based and hqp).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from ..io import outputs
from ..sim.result import SimulationResult
from ..tasks.objectives import Inequality
from .labels import figure_title, method_name

#: Colours of the overlaid runs, in order: the run itself first.
RUN_COLOURS = ("C0", "C3", "C2", "C4", "C5")
#: Line styles of the rows of one objective, in order (e.g. the joints of a joint-limits objective).
ROW_STYLES = ("-", "--", "-.", (0, (6, 1.5, 1, 1.5, 1, 1.5)), (0, (10, 3)))  # none dotted like the limits


def objective_slices(objectives: list[Inequality]) -> list[slice]:
    """The columns of each objective in the recorded ``objective_value`` (N, k) series."""
    slices, start = [], 0
    for objective in objectives:
        slices.append(slice(start, start + objective.dim))
        start += objective.dim
    return slices


def shown_value(objective: Inequality, value: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, str]:
    """(value, lower, upper, label) as drawn, in the objective's own figure units (:meth:`Inequality.shown`,
    :attr:`Inequality.unit`): joint limits as the fraction of each joint's range, a tilt in degrees, ..."""
    shown = objective.shown
    return shown(value), shown(objective.lower), shown(objective.upper), objective.unit


def band_edges(objective: Inequality) -> tuple[np.ndarray, np.ndarray]:
    """Where each row's activation starts to rise, in the drawn units (lower + band, upper - band)."""
    return (objective.shown(objective.lower + objective.band), objective.shown(objective.upper - objective.band))


def inequality_figure(result: SimulationResult, objectives: list[Inequality], title: str = "",
                      others: Mapping[str, SimulationResult] | None = None, label: str = "this run",
                      path: str | os.PathLike | None = None) -> Figure:
    """Each objective over time: its value against its valid set (dotted) and band (shaded), and its activation.

    Rows of one objective (a joint-limits objective's joints) differ by line style and are named in the panel's
    legend; runs differ by colour, named by their method (:func:`uvms.viz.labels.method_name`).

    Args:
        result: a run with the inequality series (``objective_value``, ``objective_activation``).
        objectives: the run's objectives with rows, in the recorded order
            (:attr:`uvms.scenario.inequalities.ScenarioInequalities.objectives`).
        title: the figure's title; label: the run's legend entry (a ``solver.method`` is shown by its full name).
        others: more runs of the same objectives, by label, overlaid (values only).
        path: where to write the PNG (None: not written).
    """
    runs = {method_name(name): run for name, run in {label: result, **dict(others or {})}.items()}
    count = max(len(objectives), 1)
    width = 8.0
    figure = Figure(figsize=(width, 2.3 * count + 1.0), layout="constrained")
    axes = figure.subplots(count, 1, sharex=True, squeeze=False)[:, 0]
    for axis, objective, columns in zip(axes, objectives, objective_slices(objectives)):
        draw_objective(axis, objective, columns, runs, result)
    axes[0].legend(handles=[Line2D([], [], color=colour, label=name) for colour, name in zip(RUN_COLOURS, runs)],
                   loc="upper left", fontsize=8)
    axes[-1].set_xlabel("t [s]")
    figure.suptitle(figure_title(f"{title}: inequality objectives\n(dotted: valid set, grey: activation band, "
                                 f"shaded: activation)", width))
    if path is not None:
        outputs.save_figure(figure, Path(path))
    return figure


def draw_objective(axis, objective: Inequality, columns: slice, runs: Mapping[str, SimulationResult],
                   result: SimulationResult) -> None:
    """One panel: every run's rows (colour: run, style: row), the valid set, its band and ``result``'s activation."""
    names = objective.row_names()
    for colour, run in zip(RUN_COLOURS, runs.values()):
        value, lower, upper, unit = shown_value(objective, run.objective_value[:, columns])
        for row in range(value.shape[1]):
            axis.plot(run.t, value[:, row], color=colour, linewidth=1.2, linestyle=ROW_STYLES[row % len(ROW_STYLES)])
    for bound in (*lower, *upper):
        if np.isfinite(bound):
            axis.axhline(bound, color="k", linestyle=":", linewidth=1)
    low, high = band_edges(objective)
    for bound, edge in zip((*lower, *upper), (*low, *high)):
        if np.isfinite(bound):
            axis.axhspan(min(bound, edge), max(bound, edge), color="0.85", zorder=0)
    activation = result.objective_activation[:, columns].max(axis=1)
    twin = axis.twinx()
    twin.fill_between(result.t, activation, color=RUN_COLOURS[0], alpha=0.12, step="pre")
    twin.set_ylim(0, 3.0)  # the activation in the lower third, under the values
    twin.set_yticks([0, 1])
    twin.set_ylabel("activation", fontsize=8)
    axis.set_ylabel(f"{objective.name}\n{unit}", fontsize=8)
    axis.grid(True, alpha=0.3)
    if len(names) > 1:  # which line is which row; a single row is the panel's objective itself
        rows = [Line2D([], [], color="0.3", linestyle=ROW_STYLES[row % len(ROW_STYLES)], label=name)
                for row, name in enumerate(names)]
        twin.legend(handles=rows, loc="upper right", fontsize=7, ncol=2 if len(rows) > 3 else 1, framealpha=0.8)
