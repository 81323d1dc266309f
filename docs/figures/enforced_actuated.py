"""The figure of docs/guide/enforced.md: the pipe and stow scenarios on the actuated plant, distance against time.

Runs ``scenarios/bluerov2_alpha5_pipe.toml`` and ``scenarios/bluerov2_alpha5_stow.toml`` on the actuated plant
(``--set plant.type=hydrodynamic --set plant.thrusters=true --set plant.gravity=true``) with set_based and hqp, in
still water and (pipe) in a 0.3 m/s current from ahead, plus the kinematic plant's run of the same solver for
reference; then draws per scenario the smallest distance of its collision objective over time, recomputed from each
recorded measured q with the objective built from the scenario's table, against its ``min`` (the dashed line) and
``min - 2 mm`` (issue 48's goal on the actuated plant, dotted).

    python docs/figures/enforced_actuated.py      # writes docs/figures/enforced_actuated.png (about a minute)
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

ACTUATED = ["plant.type=hydrodynamic", "plant.thrusters=true", "plant.gravity=true"]
CURRENT = ["plant.current=[-0.3, 0, 0]"]
SCENARIOS = {"pipe": ("bluerov2_alpha5_pipe", "obstacle"), "stow": ("bluerov2_alpha5_stow", "self_collision")}
#: (label, overrides, colour, line style) of each run drawn.
RUNS = {
    "pipe": [("set_based, kinematic plant", [], "0.55", ":"),
             ("set_based, actuated, still water", ACTUATED, "tab:blue", "-"),
             ("set_based, actuated, 0.3 m/s current", [*ACTUATED, *CURRENT], "tab:cyan", "-"),
             ("hqp, kinematic plant", ["solver.method=hqp"], "0.3", "--"),
             ("hqp, actuated, still water", [*ACTUATED, "solver.method=hqp"], "tab:red", "-"),
             ("hqp, actuated, 0.3 m/s current", [*ACTUATED, *CURRENT, "solver.method=hqp"], "tab:orange", "-")],
    "stow": [("set_based, kinematic plant", [], "0.55", ":"),
             ("set_based, actuated", ACTUATED, "tab:blue", "-"),
             ("hqp, kinematic plant", ["solver.method=hqp"], "0.3", "--"),
             ("hqp, actuated", [*ACTUATED, "solver.method=hqp"], "tab:red", "-")],
}


def run(toml: Path, folder: Path, overrides: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """(t (N,), q (N, nq)) of ``uvms run toml`` with the overrides into ``folder``."""
    extra = [item for override in overrides for item in ("--set", override)]
    if main(["run", str(toml), "--out", str(folder), "--quiet", "--set", "outputs.figures=false", *extra]) != 0:
        raise SystemExit(f"uvms run {toml} {' '.join(extra)} failed")
    with np.load(folder / "trajectory.npz") as arrays:
        return arrays["t"], arrays["q"]


def objective_of(toml: Path, kind: str):
    """(robot, the scenario's collision objective built from its table)."""
    robot = named_model(str(toml))
    [table] = [table.table for table in read_scenario(toml).inequalities if table.type == kind]
    [objective] = inequalities_from_table(robot, table)
    return robot, objective


def smallest(objective, robot, qs: np.ndarray) -> np.ndarray:
    """The objective's smallest distance (N,) [m] at each configuration."""
    return np.array([objective.nearest(Configuration(robot, q))[1].distance[0] for q in qs])


def main_figure(out: Path) -> None:
    figure = Figure(figsize=(12.0, 4.8), layout="constrained")
    axes = figure.subplots(1, 2)
    with tempfile.TemporaryDirectory() as tmp:
        for panel, (key, (name, kind)) in zip(axes, SCENARIOS.items()):
            toml = ROOT / "scenarios" / f"{name}.toml"
            robot, objective = objective_of(toml, kind)
            minimum = float(objective.min)
            for index, (label, overrides, colour, style) in enumerate(RUNS[key]):
                t, q = run(toml, Path(tmp) / f"{key}{index}", overrides)
                distance = smallest(objective, robot, q)
                k = int(np.argmin(distance))
                print(f"{name} {label}: smallest {1000 * distance[k]:.1f} mm at t = {t[k]:.2f} s")
                panel.plot(t, 1000 * distance, color=colour, linestyle=style,
                           label=f"{label} (min {1000 * distance.min():.1f} mm)")
            panel.axhline(1000 * minimum, color="k", linestyle="--", linewidth=1.0,
                          label=f"min = {1000 * minimum:g} mm")
            panel.axhline(1000 * minimum - 2.0, color="k", linestyle=":", linewidth=1.0,
                          label="min - 2 mm (the actuated goal)")
            panel.set_title(f"({'ab'[list(SCENARIOS).index(key)]}) {name}: smallest {kind} distance")
            panel.set_xlabel("t [s]")
            panel.set_ylabel("distance [mm]")
            panel.set_ylim(1000 * minimum - 6.0, 1000 * minimum + 40.0)
            panel.grid(alpha=0.3)
            panel.legend(fontsize=7, loc="upper right")
    save_figure(figure, out)


if __name__ == "__main__":
    main_figure(Path(__file__).with_suffix(".png"))
