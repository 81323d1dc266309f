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

from ..io import outputs
from ..sim.result import SimulationResult
from ..tasks.objectives import FrameBox, Inequality, JointLimits, Manipulability, PlaneClearance, VehicleAttitude

#: Colours of the overlaid runs, in order: the run itself first.
RUN_COLOURS = ("C0", "C3", "C2", "C4", "C5")


def objective_slices(objectives: list[Inequality]) -> list[slice]:
    """The columns of each objective in the recorded ``objective_value`` (N, k) series."""
    slices, start = [], 0
    for objective in objectives:
        slices.append(slice(start, start + objective.dim))
        start += objective.dim
    return slices


def shown_value(objective: Inequality, value: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, str]:
    """(value, lower, upper, label) as drawn: joint limits as the fraction of each joint's range, a tilt in degrees,
    the rest in their own units."""
    lower, upper = objective.lower, objective.upper
    if isinstance(objective, JointLimits):
        width = upper - lower
        return (value - lower) / width, np.zeros_like(lower), np.ones_like(upper), "position in range [-]"
    if isinstance(objective, VehicleAttitude):
        return np.degrees(value), np.degrees(lower), np.degrees(upper), "tilt [deg]"
    unit = ("distance [m]" if isinstance(objective, PlaneClearance) else "position [m]"
            if isinstance(objective, FrameBox) else "manipulability" if isinstance(objective, Manipulability)
            else "value")
    return value, lower, upper, unit


def band_edges(objective: Inequality) -> tuple[np.ndarray, np.ndarray]:
    """Where each row's activation starts to rise, in the drawn units (lower + band, upper - band)."""
    low, high = objective.lower + objective.band, objective.upper - objective.band
    if isinstance(objective, JointLimits):
        width = objective.upper - objective.lower
        return (low - objective.lower) / width, (high - objective.lower) / width
    if isinstance(objective, VehicleAttitude):
        return np.degrees(low), np.degrees(high)
    return low, high


def inequality_figure(result: SimulationResult, objectives: list[Inequality], title: str = "",
                      others: Mapping[str, SimulationResult] | None = None, label: str = "this run",
                      path: str | os.PathLike | None = None) -> Figure:
    """Each objective over time: its value against its valid set (dotted) and band (shaded), and its activation.

    Args:
        result: a run with the inequality series (``objective_value``, ``objective_activation``).
        objectives: the run's objectives with rows, in the recorded order
            (:attr:`uvms.scenario.inequalities.ScenarioInequalities.objectives`).
        title: the figure's title; label: the run's legend entry.
        others: more runs of the same objectives, by label, overlaid (values only).
        path: where to write the PNG (None: not written).
    """
    runs = {label: result, **dict(others or {})}
    count = max(len(objectives), 1)
    figure = Figure(figsize=(8, 2.1 * count + 0.8))
    axes = figure.subplots(count, 1, sharex=True, squeeze=False)[:, 0]
    for axis, objective, columns in zip(axes, objectives, objective_slices(objectives)):
        for colour, (name, run) in zip(RUN_COLOURS, runs.items()):
            value, lower, upper, unit = shown_value(objective, run.objective_value[:, columns])
            for row in range(value.shape[1]):
                axis.plot(run.t, value[:, row], color=colour, linewidth=1.2,
                          label=name if row == 0 else None)
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
    axes[0].legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel("t [s]")
    figure.suptitle(f"{title}: inequality objectives (dotted: valid set, grey: activation band)")
    figure.tight_layout()
    if path is not None:
        outputs.save_figure(figure, Path(path))
    return figure
