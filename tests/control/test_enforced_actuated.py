"""Issue 48's goals on the actuated plant, recomputed from the recorded measured state (short runs of the shipped
scenarios): the end-effector error by forward kinematics against the recorded desired point, the tilt from the base
rotation, the pipe distance with coal on the model's collision shapes (benchmarks/actuated_goals.py: the full table).
"""

from __future__ import annotations

from pathlib import Path

import coal
import numpy as np
import pinocchio as pin
import pytest

import uvms
from uvms.model.collision import collision_geometry
from uvms.scenario import run_scenario

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = ROOT / "scenarios"
ACTUATED = ["plant.type=hydrodynamic", "plant.thrusters=true", "plant.gravity=true", "outputs.figures=false"]


@pytest.fixture(scope="module")
def robot() -> uvms.Robot:
    return uvms.load("bluerov2_alpha5")


def _run(tmp_path: Path, name: str, overrides: list[str]) -> dict:
    run_scenario(SCENARIOS / f"{name}.toml", tmp_path / name, ["outputs.figures=false", *overrides], progress=False)
    with np.load(tmp_path / name / "trajectory.npz") as arrays:
        return dict(arrays)


def _tilts(robot, qs: np.ndarray) -> np.ndarray:
    return np.array([np.arccos(np.clip(robot.base_pose(q).rotation[2, 2], -1.0, 1.0)) for q in qs])


def test_the_moving_task_tracks_within_a_centimetre(robot, tmp_path):
    """bluerov2_alpha5_moving_task's first 2.5 s (its largest error, at t ~ 2 s, was there): the vehicle starts at
    rest in a 0.3 m/s current its model does not have. Measured: under 1 cm with the disturbance observer (6.6 mm
    over the whole run); 2.8 cm without (the integral trails the current's drag, which grows as the vehicle speeds up
    through the water)."""
    errors = {}
    for constant in (0.1, 0.0):
        series = _run(tmp_path / str(constant), "bluerov2_alpha5_moving_task",
                      ["simulation.duration=2.5", f"vehicle_control.disturbance_time_constant={constant}"])
        points = np.array([robot.fk(q, "ee").translation for q in series["q"]])
        errors[constant] = float(np.linalg.norm(points - series["desired_position"], axis=1).max())
    assert errors[0.1] < 0.01 < 0.02 < errors[0.0], errors


def test_the_saturated_current_keeps_the_tilt(robot, tmp_path):
    """bluerov2_alpha5_intervention_saturated_current's first 4 s (its largest tilt without the observer, 0.097 rad
    at t = 3.7 s, beyond the objective's 0.0873): the tilt recomputed from the recorded q stays 0.02 rad inside the
    maximum. Measured: 0.035 rad (0.097 without the disturbance observer)."""
    series = _run(tmp_path, "bluerov2_alpha5_intervention_saturated_current", ["simulation.duration=4.0"])
    assert _tilts(robot, series["q"]).max() < 0.0873 - 0.02


def _pipe_distances(robot, qs: np.ndarray) -> np.ndarray:
    """min over the robot's collision shapes of coal's signed distance to the scenario's pipe (N,) [m]."""
    geometry = collision_geometry(robot)
    pipe = coal.Cylinder(0.06, 2.0)
    pose = coal.Transform3s(pin.rpy.rpyToMatrix(1.5707963, 0.0, 0.0), np.array([0.5, 0.0, -5.42]))
    data, geometry_data = robot.model.createData(), pin.GeometryData(geometry)
    request = coal.DistanceRequest()
    request.enable_signed_distance = True
    out = []
    for q in qs:
        pin.updateGeometryPlacements(robot.model, data, geometry, geometry_data, q)
        out.append(min(coal.distance(item.geometry, coal.Transform3s(placement.rotation, placement.translation),
                                     pipe, pose, request, coal.DistanceResult())
                       for item, placement in zip(geometry.geometryObjects, geometry_data.oMg)))
    return np.array(out)


def test_pipe_hqp_on_the_actuated_plant_keeps_its_minimum(robot, tmp_path):
    """bluerov2_alpha5_pipe with hqp on the actuated plant, its first 6 s (the jaws reach the pipe at about 5.5 s):
    the collision objective tightened by its measured tracking error keeps every shape 2 cm from the pipe on the
    measured state. Measured (coal, every 4th row): 21.0 mm; 19.0 mm with vehicle_control.tightening = false."""
    series = _run(tmp_path, "bluerov2_alpha5_pipe", [*ACTUATED, "solver.method=hqp", "simulation.duration=6.0"])
    assert _pipe_distances(robot, series["q"][::4]).min() > 0.02 - 1e-4
