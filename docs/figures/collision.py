"""The figure of docs/guide/collision.md: the two shipped collision scenarios with and without their objectives.

Runs ``scenarios/bluerov2_alpha5_stow.toml`` and ``scenarios/bluerov2_alpha5_pipe.toml`` as shipped (set-based, the
collision objective above the task) and with ``--set solver.method=clik`` (the objectives only monitored), then draws
per scenario (one row each: (a)-(c), then (d)-(f)) the smallest distance of its collision objective over time,
recomputed from each trajectory with the objective built from the scenario's table, against its ``min``; then the
x-z side view at the moment of the smallest distance with and without: the collision shapes
(``uvms view --collision``), the obstacle and the closest pair (named with its distance below the panel), a square of
0.5 m around the pair. A key below the panels explains the shapes, the pair's colours and the RGB frame axes.

    python docs/figures/collision.py            # writes docs/figures/collision.png
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
# uvms after the line above (E402): this checkout's, not an installed one
from uvms.cli import main  # noqa: E402
from uvms.io.outputs import save_figure  # noqa: E402
from uvms.robot.configuration import Configuration  # noqa: E402
from uvms.scenario.record import named_model  # noqa: E402
from uvms.scenario.schema import read_scenario  # noqa: E402
from uvms.tasks.objectives import inequalities_from_table  # noqa: E402
from uvms.viz.collision_drawing import CollisionOverlay  # noqa: E402
from uvms.viz.drawing import (  # noqa: E402
    configuration_geometry,
    draw_configuration,
    legend_entries,
    set_equal_limits,
)
from uvms.viz.labels import legend_below, legend_under  # noqa: E402

SCENARIOS = {"stow": ("bluerov2_alpha5_stow", "self_collision"), "pipe": ("bluerov2_alpha5_pipe", "obstacle")}
RUNS = {"with": [], "without": ["--set", "solver.method=clik"]}
COLOURS = {"with": "tab:blue", "without": "tab:red"}
PLANE = "xz"
#: Side of the drawn square around the closest pair [m].
WINDOW = 0.5
#: Triad length of the side views [m].
TRIAD = 0.04


def run(toml: Path, folder: Path, extra: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """(t (N,), q (N, nq)) of ``uvms run toml`` into ``folder``."""
    if main(["run", str(toml), "--out", str(folder), "--quiet", "--set", "outputs.figures=false", *extra]) != 0:
        raise SystemExit(f"uvms run {toml} {' '.join(extra)} failed")
    with np.load(folder / "trajectory.npz") as arrays:
        return arrays["t"], arrays["q"]


def smallest(objective, robot, qs: np.ndarray) -> np.ndarray:
    """The objective's smallest distance (N,) [m] at each configuration."""
    return np.array([objective.nearest(Configuration(robot, q))[1].distance[0] for q in qs])


def side_view(ax, robot, overlay: CollisionOverlay, q: np.ndarray, title: str) -> None:
    """The x-z view of q with the collision shapes, the obstacle and the closest pair, framed on the pair (a
    square of side :data:`WINDOW`)."""
    draw_configuration(ax, robot, q, plane=PLANE, autoscale=False, triad_length=TRIAD)
    marks = overlay.draw(ax, q, PLANE)
    centre = (marks.closest[0].point1 + marks.closest[0].point2) / 2
    window = centre + WINDOW / 2 * np.array([[-1.0, -1.0, -1.0], [1.0, 1.0, 1.0]])
    set_equal_limits(ax, window, PLANE, margin=0.0)
    overlay.draw_obstacles(ax, window, PLANE)
    ax.set_title(title, fontsize=9)


def main_figure(out: Path) -> None:
    figure = Figure(figsize=(13.5, 9.6), layout="constrained")
    grid = figure.add_gridspec(2, 3, width_ratios=[1.3, 1, 1])
    with tempfile.TemporaryDirectory() as scratch:
        for row, (key, (name, kind)) in enumerate(SCENARIOS.items()):
            toml = ROOT / "scenarios" / f"{name}.toml"
            robot = named_model(str(toml))
            [table] = [table.table for table in read_scenario(toml).inequalities if table.type == kind]
            [objective] = inequalities_from_table(robot, table)
            overlay = CollisionOverlay(robot, True, [objective])
            curve = figure.add_subplot(grid[row, 0])
            for column, (label, extra) in enumerate(RUNS.items(), start=1):
                t, qs = run(toml, Path(scratch) / f"{key}_{label}", extra)
                distance = smallest(objective, robot, qs)
                k = int(np.argmin(distance))
                print(f"{name} {label}: smallest {1000 * distance[k]:.1f} mm at t = {t[k]:.2f} s")
                curve.plot(t, 1000 * distance, color=COLOURS[label], linewidth=1.2,
                           label=f"{label} (smallest: {1000 * distance[k]:.1f} mm at {t[k]:.2f} s)")
                curve.plot(t[k], 1000 * distance[k], "o", color=COLOURS[label])
                solver = "set-based" if label == "with" else "CLIK, monitored only"
                side_view(figure.add_subplot(grid[row, column]), robot, overlay, qs[k],
                          f"({'abcdef'[3 * row + column]}) {label} ({solver}): t = {t[k]:.2f} s")
            curve.axhline(1000 * objective.min, color="0.3", linestyle="--",
                          label=f"min = {1000 * objective.min:.0f} mm")
            curve.axhline(0.0, color="0.6", linewidth=0.8)
            curve.set_xlabel("t [s]")
            curve.set_ylabel(f"smallest {kind} distance [mm]")
            curve.set_title(f"({'abcdef'[3 * row]}) {name}", fontsize=10)
            legend_under(curve, *curve.get_legend_handles_labels(), fontsize=7.5)
            curve.grid(alpha=0.3)
            key = legend_entries(configuration_geometry(robot, qs[k], triad_length=TRIAD)) + overlay.legend_entries()
    legend_below(figure, key, columns=len(key), fontsize=8.5)
    save_figure(figure, out)
    print(f"wrote {out}")


if __name__ == "__main__":
    main_figure(Path(__file__).with_suffix(".png"))
