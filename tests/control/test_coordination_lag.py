"""The chain keeps the objectives on the measured vehicle (issue 48): the arm's servo lag inverted over the step, the
reference's acceleration fed forward, the arm's speed limits held by the hierarchy. Every number is recomputed from
the recorded measured state (trajectory.npz): distances with coal, the end-effector error with Pinocchio's FK.
The full-length goal table: benchmarks/actuated_goals.py."""

from __future__ import annotations

from pathlib import Path

import coal
import numpy as np
import pinocchio as pin
import pytest

import uvms
from uvms.model.collision import collision_geometry
from uvms.scenario import run_scenario

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"
ACTUATED = ["plant.type=hydrodynamic", "plant.thrusters=true", "plant.gravity=true", "outputs.figures=false"]
OLD_CHAIN = ["vehicle_control.servo_compensation=false", "vehicle_control.acceleration_feedforward=false"]


@pytest.fixture(scope="module")
def robot() -> uvms.Robot:
    return uvms.load("bluerov2_alpha5")


def pipe_distance(robot: uvms.Robot, q_series: np.ndarray) -> float:
    """min over time and the robot's collision shapes of coal's signed distance to the scenario's pipe [m]."""
    geometry = collision_geometry(robot)
    data, geometry_data = robot.model.createData(), pin.GeometryData(geometry)
    pipe = coal.Cylinder(0.06, 2.0)
    pipe_pose = coal.Transform3s(pin.rpy.rpyToMatrix(1.5707963, 0.0, 0.0), np.array([0.5, 0.0, -5.42]))
    request, result = coal.DistanceRequest(), coal.DistanceResult()
    distances = []
    for q in q_series:
        pin.updateGeometryPlacements(robot.model, data, geometry, geometry_data, q)
        for item, placement in zip(geometry.geometryObjects, geometry_data.oMg):
            pose = coal.Transform3s(placement.rotation, placement.translation)
            distances.append(coal.distance(item.geometry, pose, pipe, pipe_pose, request, result))
    return float(min(distances))


def ee_error(robot: uvms.Robot, folder: Path) -> float:
    """max |FK(q) - desired| [m] over the recorded measured q."""
    recorded = np.load(folder / "trajectory.npz")
    points = np.array([robot.fk(q, "ee").translation for q in recorded["q"]])
    return float(np.linalg.norm(points - recorded["desired_position"], axis=1).max())


def test_the_pipe_is_kept_on_the_measured_robot(robot, tmp_path):
    """The pipe scenario on the actuated plant, its line run in 3 s: every measured shape stays 2 cm from the pipe
    within 2 mm (measured 22.7 mm; the chain before issue 48, the joint rates clipped after the solve and the
    servo's lag left: -0.3 mm, inside the pipe)."""
    short = [*ACTUATED, "trajectory.duration=3.0", "simulation.duration=4.0"]
    run_scenario(SCENARIOS / "bluerov2_alpha5_pipe.toml", tmp_path / "p", short, progress=False)
    recorded = np.load(tmp_path / "p" / "trajectory.npz")
    assert pipe_distance(robot, recorded["q"][::2]) > 0.018


def test_the_moving_task_follows_within_three_centimetres(robot, tmp_path):
    """bluerov2_alpha5_moving_task's first 2.5 s (its largest error is near 2 s): measured 2.8 cm; the chain before
    issue 48 (the joint rates clipped after the solve, the servo's lag left, no reference acceleration): 11.7 cm;
    with the hierarchy's speed limits but without the two compensations: 3.3 cm."""
    scenario = SCENARIOS / "bluerov2_alpha5_moving_task.toml"
    short = ["outputs.figures=false", "simulation.duration=2.5"]
    run_scenario(scenario, tmp_path / "new", short, progress=False)
    run_scenario(scenario, tmp_path / "old", [*short, *OLD_CHAIN], progress=False)
    new, old = ee_error(robot, tmp_path / "new"), ee_error(robot, tmp_path / "old")
    assert new < 0.03 and new < 0.95 * old, (new, old)
