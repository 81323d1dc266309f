"""AUVs with fins on the actuated chain: the torpedo (one propeller, four uuv_simulator fins) and the LRAUV-like
vehicle (Gazebo Sim LiftDrag fins) run a 5 m straight line at 1 m/s, the fins holding the attitude."""

import json
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import uvms.scenario.actuated
from uvms.dynamics.thrusters.fins import Fins
from uvms.errors import (
    BaseGuessWarning,
    FinDefaultWarning,
    PointMassWarning,
    ThrusterLayoutWarning,
)
from uvms.scenario.runs import run_scenario

AUV = Path(__file__).parents[1] / "fixtures" / "auv"
NO_FIGURES = ["outputs.figures=false"]


def run_torpedo(out: Path, overrides=()):
    with pytest.warns(PointMassWarning), pytest.warns(BaseGuessWarning), \
            pytest.warns(ThrusterLayoutWarning, match="the thrusters produce 1 of the 6"):
        return run_scenario(AUV / "straight.toml", out=out, overrides=list(overrides), progress=False)


def tilt(run) -> float:
    """The largest angle [rad] between the vehicle's z axis and the world's over the run."""
    return max(float(np.arccos(np.clip(run.simulation.robot.base_pose(q).rotation[2, 2], -1.0, 1.0)))
               for q in run.simulation.q)


def test_the_torpedo_runs_its_straight_line_with_its_propeller_and_fins(tmp_path):
    """Before: refused (fins as arm joints). Now it travels the 5 m line (goal: >= 4 m), within 0.3 m of it, level
    within 1e-3 rad; the elevators work (the rudders have nothing to do on a symmetric straight run)."""
    run = run_torpedo(tmp_path / "run")
    q = run.simulation.q
    assert q[-1, 0] - q[0, 0] > 5.0 and abs(q[-1, 1]) < 1e-3 and abs(q[-1, 2] - q[0, 2]) < 0.01
    assert run.metrics["verdict"]["ok"] and run.metrics["max_position_error"] < 0.25
    assert tilt(run) < 1e-3
    metrics = json.loads((tmp_path / "run" / "metrics.json").read_text())
    assert metrics["fins"] == [f"torpedo_fin{i}_model" for i in range(4)]
    with np.load(tmp_path / "run" / "actuation.npz") as saved:
        angles, thrusts, commands = saved["fin_angles"], saved["thrusts"], saved["thrust_command"]
    assert angles.shape == (len(run.simulation.t), 4) and np.all(np.abs(angles) <= 0.4 + 1e-12)
    assert np.max(np.abs(angles[:, [0, 2]])) > 0.05 and np.max(np.abs(angles[:, [1, 3]])) < 1e-9
    cruise = np.median(thrusts[(run.simulation.t > 4.0) & (run.simulation.t < 5.0), 0])
    assert commands.min() == pytest.approx(-20.0) and 5.0 < cruise < 12.0  # brakes at the reverse limit; cruises
    assert (tmp_path / "run" / "thrusters.png").stat().st_size > 10_000


def test_without_its_fins_the_torpedo_tilts_forty_times_more(tmp_path, monkeypatch):
    """The same run with the fins' plugins ignored: the propeller alone cannot hold the pitch that the tail's
    point masses and the hull's Munk moment give (0.04 rad against 2e-4 with the fins)."""
    with_fins = tilt(run_torpedo(tmp_path / "fins", NO_FIGURES))
    monkeypatch.setattr(uvms.dynamics.plant.actuated, "fins_of", lambda robot: Fins())
    without = tilt(run_torpedo(tmp_path / "none", NO_FIGURES))
    assert with_fins < 1e-3 and without > 0.02, (with_fins, without)


def test_an_auv_with_gazebo_sim_lift_drag_fins_runs_the_line(tmp_path):
    with pytest.warns(FinDefaultWarning), pytest.warns(ThrusterLayoutWarning, match="the 2 fins' lift adds 2"):
        run = run_scenario(AUV / "gz_lrauv" / "straight.toml", out=tmp_path / "run", overrides=NO_FIGURES,
                           progress=False)
    q = run.simulation.q
    assert q[-1, 0] - q[0, 0] > 4.9 and run.metrics["verdict"]["ok"] and run.metrics["max_position_error"] < 0.1
    assert tilt(run) < 0.01
    rpy = pin.rpy.matrixToRpy(run.simulation.robot.base_pose(q[-1]).rotation)
    assert abs(rpy[2]) < 1e-6  # the vertical fin holds the heading
