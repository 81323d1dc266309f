"""Figures of an actuated run: the thrusts against their limits, and how well the vehicle and the end effector hold.

``thrusters.png``: one panel per thruster, its thrust [N] and the command, the forward and reverse limits dotted;
then one per fin, its angle [rad] and the command, its limits dotted.
``station.png``: the vehicle's position [m] and attitude [rad] errors from its station and the end effector's
distance [m] from the held point. :func:`coordination_figure` overlays runs (with and without coordination).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from ..dynamics.thrusters.fins import Fins
from ..dynamics.thrusters.thrusters import Thrusters
from ..io import outputs
from ..sim.result import SimulationResult

FLOOR = 1e-9  # [m, rad] log axes: errors below are drawn at the floor


def log_bottom(values: list[np.ndarray]) -> float:
    """A lower limit for a log axis from the data: the decade of their 1st percentile (the errors start at 0)."""
    positive = np.concatenate([v[v > FLOOR] for v in values]) if values else np.zeros(0)
    return 10.0 ** np.floor(np.log10(np.percentile(positive, 1))) if positive.size else FLOOR


def thrust_figure(result: SimulationResult, thrusters: Thrusters, title: str = "", fins: Fins | None = None) -> Figure:
    """Each thruster's thrust and saturated command [N] over time, its limits dotted, then each fin's angle and
    command [rad] (2 per row)."""
    fins = Fins() if fins is None or result.actuation.series("fin_angles") is None else fins
    panels = [(result.actuation.thrusts[:, i], result.actuation.thrust_command[:, i], thrusters.lower[i],
               thrusters.upper[i], f"{thrusters.names[i]} [N]") for i in range(len(thrusters))]
    panels += [(result.actuation.series("fin_angles")[:, i], result.actuation.series("fin_command")[:, i],
                fins.lower[i], fins.upper[i], f"{fins.names[i]} [rad]") for i in range(len(fins))
               if fins.items[i].moves]  # a fixed lifting surface has no angle to draw
    count = len(panels)
    columns = 2 if count > 1 else 1
    rows = int(np.ceil(count / columns))
    figure = Figure(figsize=(9, 1.7 * rows + 0.8), layout="constrained")  # the title above the panels
    axes = figure.subplots(rows, columns, sharex=True, squeeze=False).reshape(-1)
    for index, axis in enumerate(axes):
        if index >= count:
            axis.set_visible(False)
            continue
        values, commands, lower, upper, label = panels[index]
        axis.plot(result.t, commands, color="C1", linewidth=0.8, label="command (saturated)")
        axis.plot(result.t, values, color="C0", label="thrust or angle")
        for bound in (lower, upper):
            axis.axhline(bound, color="k", linestyle=":", linewidth=1)
        axis.set_ylabel(label, fontsize=8)
        axis.grid(True, alpha=0.3)
    axes[0].legend(fontsize=7, loc="lower right")
    for axis in axes[-columns:]:
        axis.set_xlabel("t [s]")
    what = "thrusts and fin angles" if len(fins) else "thrusts"
    figure.suptitle(f"{title}: {what} (dotted: the limits)")
    return figure


def coordination_figure(runs: Mapping[str, SimulationResult], title: str = "") -> Figure:
    """Vehicle position and attitude errors and the end effector's distance from its point, for one or more runs."""
    figure = Figure(figsize=(8, 6.4), layout="constrained")
    axes = figure.subplots(3, 1, sharex=True)
    series = (("vehicle_position_error", "vehicle position error [m]"),
              ("vehicle_attitude_error", "vehicle attitude error [rad]"),
              ("ee_point_error", "end-effector error [m]"))
    for label, result in runs.items():
        for axis, (name, _) in zip(axes, series):
            values = result.actuation.series(name)
            if values is not None:
                axis.semilogy(result.t, np.maximum(values, FLOOR), label=label)
    for axis, (name, ylabel) in zip(axes, series):
        axis.set_ylim(bottom=log_bottom([run.actuation.series(name) for run in runs.values()
                                         if run.actuation.series(name) is not None]))
        axis.set_ylabel(ylabel, fontsize=8)
        axis.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=8)
    axes[-1].set_xlabel("t [s]")
    figure.suptitle(f"{title}: the vehicle on its station, the end effector on its trajectory")
    return figure


def comparison_figure(runs: Mapping[str, SimulationResult], title: str = "",
                      clearance: tuple[float, float] | None = None) -> Figure:
    """Runs side by side, kinematic or actuated: the end-effector error [m], the vehicle's distance from where it
    started [m] and its tilt [rad] (the angle of its z axis from the world's); ``clearance``: (the seabed's
    height, the minimum [m]) adds the vehicle's clearance above it."""
    panels = 4 if clearance is not None else 3
    figure = Figure(figsize=(8, 1.9 * panels + 0.6), layout="constrained")
    axes = figure.subplots(panels, 1, sharex=True)
    for label, result in runs.items():
        robot = result.robot
        poses = [robot.base_pose(q, check=False) for q in result.q]  # a result's rows: checked once as a whole
        start = poses[0].translation
        axes[0].plot(result.t, result.position_error, label=label)
        axes[1].plot(result.t, [np.linalg.norm(pose.translation - start) for pose in poses], label=label)
        axes[2].plot(result.t, [np.arccos(np.clip(pose.rotation[2, 2], -1.0, 1.0)) for pose in poses], label=label)
        if clearance is not None:
            axes[3].plot(result.t, [pose.translation[2] - clearance[0] for pose in poses], label=label)
    labels = ["end-effector error [m]", "vehicle from its start [m]", "vehicle tilt [rad]", "seabed clearance [m]"]
    for axis, ylabel in zip(axes, labels):
        axis.set_ylabel(ylabel, fontsize=8)
        axis.grid(True, alpha=0.3)
    if clearance is not None:
        axes[3].axhline(clearance[1], color="k", linestyle=":", linewidth=1)
    axes[0].legend(fontsize=8)
    axes[-1].set_xlabel("t [s]")
    figure.suptitle(title)
    return figure


def actuated_figures(result: SimulationResult, thrusters: Thrusters, folder: str | os.PathLike,
                     title: str = "", fins: Fins | None = None) -> list[Path]:
    """Write ``thrusters.png`` (with the fins' angles) and ``station.png`` of an actuated run into ``folder``
    (station.png when the run kept a station: an open-loop excitation has none); returns their paths."""
    folder = Path(folder)
    figures = {"thrusters.png": thrust_figure(result, thrusters, title, fins)}
    if result.actuation.series("vehicle_position_error") is not None:
        figures["station.png"] = coordination_figure({"this run": result}, title)
    for name, figure in figures.items():
        outputs.save_figure(figure, folder / name)
    return [folder / name for name in figures]
