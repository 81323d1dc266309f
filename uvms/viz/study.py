"""Figures of a Monte Carlo study (:mod:`uvms.scenario.studies.study`): histograms, scatter plots, sensitivity
ranking."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

from ..io import outputs
from .labels import plain_text

PASS_COLOR, FAIL_COLOR = "tab:blue", "tab:red"


def finite(values: Sequence) -> list[float]:
    return [float(v) for v in values if isinstance(v, (int, float)) and math.isfinite(v)]


def save_study_figures(table: Sequence[dict], keys: Sequence[str], metrics: Sequence[str], summary: dict,
                       folder: Path, title: str = "") -> list[Path]:
    """Write ``study_histograms.png``, ``study_scatter.png`` and ``study_sensitivity.png`` into ``folder``.

    Args:
        table: the rows of ``study.csv`` (sampled values under their keys, metrics, ``pass``, ``error``).
        keys: the sampled keys; metrics: the metric columns; summary: ``summary.json`` (pass rate, sensitivity).

    Returns:
        The paths written (none if no trial ran: no metric).
    """
    rate = summary["pass_rate"]
    head = (f"{plain_text(title)}: {rate['trials']} trials, pass rate {rate['rate']:.0%} "
            f"({rate['confidence']:.0%} CI {rate['ci_low']:.0%}-{rate['ci_high']:.0%})")
    if not metrics:  # every trial failed: nothing to draw
        return []
    paths = [folder / "study_histograms.png", folder / "study_scatter.png", folder / "study_sensitivity.png"]
    histograms(table, metrics, head, paths[0])
    scatter(table, keys, metrics, head, paths[1])
    ranking(summary["sensitivity"], metrics, head, paths[2])
    return paths


def histograms(table: Sequence[dict], metrics: Sequence[str], head: str, path: Path) -> None:
    """One histogram per metric, passed and not passed trials stacked."""
    from matplotlib.figure import Figure
    from matplotlib.ticker import MaxNLocator

    columns = min(3, len(metrics))
    lines = math.ceil(len(metrics) / columns)
    figure = Figure(figsize=(3.6 * columns, 2.8 * lines + 0.6))
    axes = figure.subplots(lines, columns, squeeze=False).ravel()
    for axis, metric in zip(axes, metrics):
        passed = finite(row[metric] for row in table if row["pass"])
        failed = finite(row[metric] for row in table if not row["pass"])
        if passed or failed:
            axis.hist([passed, failed], bins=20, stacked=True, color=[PASS_COLOR, FAIL_COLOR],
                      label=["pass", "fail"])
        axis.set_xlabel(metric.replace("_", " "), fontsize=8)
        axis.set_ylabel("trials", fontsize=8)
        axis.tick_params(labelsize=7)
        axis.xaxis.set_major_locator(MaxNLocator(5))  # a narrow range's long labels would run into each other
        axis.yaxis.set_major_locator(MaxNLocator(integer=True))  # counts of trials
    axes[0].legend(fontsize=7)
    for axis in axes[len(metrics):]:
        axis.set_visible(False)
    figure.suptitle(head, fontsize=9)
    figure.tight_layout()
    outputs.save_figure(figure, path)


def scatter(table: Sequence[dict], keys: Sequence[str], metrics: Sequence[str], head: str, path: Path) -> None:
    """Each metric (rows) against each sampled key (columns); blue: passed, red: not passed."""
    from matplotlib.figure import Figure

    figure = Figure(figsize=(2.8 * len(keys) + 0.8, 2.0 * len(metrics) + 0.6))
    axes = figure.subplots(len(metrics), len(keys), squeeze=False, sharex="col", sharey="row")
    for j, key in enumerate(keys):
        labels = list(dict.fromkeys(plain_text(row[key]) for row in table))
        numeric = all(isinstance(row[key], (int, float)) for row in table)
        for i, metric in enumerate(metrics):
            axis = axes[i, j]
            for passed, color in ((True, PASS_COLOR), (False, FAIL_COLOR)):
                rows = [row for row in table if bool(row["pass"]) == passed and isinstance(row[metric], float)
                        and math.isfinite(row[metric])]
                xs = [row[key] if numeric else labels.index(plain_text(row[key])) for row in rows]
                axis.plot(xs, [row[metric] for row in rows], ".", color=color, markersize=4)
            if j == 0:
                axis.set_ylabel(metric.replace("_", " "), fontsize=7)
            axis.tick_params(labelsize=6)
            axis.grid(True, alpha=0.3)
            axis.locator_params(nbins=4)  # a small panel reads 4-5 ticks (matplotlib makes each tick's artists)
        if not numeric:
            axes[-1, j].set_xticks(range(len(labels)), labels, fontsize=6)
        axes[-1, j].set_xlabel(plain_text(key), fontsize=7)
    figure.suptitle(head, fontsize=9)
    figure.tight_layout()
    outputs.save_figure(figure, path)


def ranking(sensitivity: dict, metrics: Sequence[str], head: str, path: Path) -> None:
    """The first-order index eta^2 of each key, one panel per outcome (metrics and pass), keys ranked; Spearman's
    rho on the bars."""
    from matplotlib.figure import Figure

    outcomes = [m for m in [*metrics, "pass"] if sensitivity.get(m)]
    columns = min(3, max(len(outcomes), 1))
    lines = max(1, math.ceil(len(outcomes) / columns))
    figure = Figure(figsize=(4.4 * columns, 0.4 * len(sensitivity.get("pass", [])) * lines + 1.6 * lines + 0.6))
    axes = figure.subplots(lines, columns, squeeze=False).ravel()
    for axis, outcome in zip(axes, outcomes):
        entries = sensitivity[outcome][::-1]  # the strongest at the top
        axis.barh(range(len(entries)), [e["eta2"] or 0.0 for e in entries], color="tab:blue")
        axis.set_yticks(range(len(entries)), [plain_text(e["key"]) for e in entries], fontsize=7)
        for y, entry in enumerate(entries):
            rho = "" if entry["rho"] is None else f"rho {entry['rho']:+.2f} (p {entry['p_value']:.1g})"
            x, align, color = rho_place(entry["eta2"] or 0.0)
            axis.text(x, y, "const." if entry["eta2"] is None else rho, va="center", ha=align, color=color,
                      fontsize=6)
        axis.set_xlim(0, 1)
        axis.set_title(outcome.replace("_", " "), fontsize=8)
        axis.tick_params(axis="x", labelsize=7)
    for axis in axes[len(outcomes):]:
        axis.set_visible(False)
    for axis in axes[(lines - 1) * columns:]:
        axis.set_xlabel("eta^2: variance explained by the key alone", fontsize=7)
    figure.suptitle(head, fontsize=9)
    figure.tight_layout()
    outputs.save_figure(figure, path)


def rho_place(eta2: float) -> tuple[float, str, str]:
    """(x, ha, color) of a ranking bar's label: after the bar's end when it fits there (a label at 6 pt is a third of
    the panel's width at most), else inside the bar's end in white, so that it never runs over the bar."""
    return (eta2 + 0.02, "left", "black") if eta2 <= 0.6 else (eta2 - 0.02, "right", "white")


def save_tune_history(rows: Sequence[dict], keys: Sequence[str], objective: str, direction: str, path: Path,
                      title: str = "") -> None:
    """The optimisation history of ``uvms tune``: the objective per trial and the best so far, then each
    parameter per trial (the best trial circled)."""
    from matplotlib.figure import Figure

    figure = Figure(figsize=(7, 2.4 * (1 + len(keys)) + 0.4))
    axes = figure.subplots(1 + len(keys), 1, sharex=True, squeeze=False)[:, 0]
    trials = [row["trial"] for row in rows]
    values = [row["value"] for row in rows]
    best, running = [], math.nan
    for value in values:
        if math.isfinite(value) and (math.isnan(running) or (value > running if direction == "maximize"
                                                                 else value < running)):
            running = value
        best.append(running)
    axes[0].plot(trials, values, "o", color="tab:blue", markersize=4, label="trial")
    axes[0].plot(trials, best, "-", color="tab:red", label=f"best so far ({direction})")
    axes[0].set_ylabel(objective.replace("_", " "), fontsize=8)
    axes[0].legend(fontsize=7)
    finite = [row for row in rows if math.isfinite(row["value"])]
    chosen = (max if direction == "maximize" else min)(finite, key=lambda row: row["value"]) if finite else None
    for axis, key in zip(axes[1:], keys):
        axis.plot(trials, [row[key] for row in rows], "o", color="tab:gray", markersize=4)
        if chosen is not None:
            axis.plot([chosen["trial"]], [chosen[key]], "o", markersize=10, markerfacecolor="none", color="tab:red")
        axis.set_ylabel(plain_text(key), fontsize=8)
    for axis in axes:
        axis.grid(True, alpha=0.3)
        axis.tick_params(labelsize=7)
    axes[-1].set_xlabel("trial")
    figure.suptitle(f"{plain_text(title)}: tuning {len(rows)} trials (Optuna TPE)", fontsize=9)
    figure.tight_layout()
    outputs.save_figure(figure, path)


__all__ = ["save_study_figures", "save_tune_history"]
