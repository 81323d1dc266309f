"""Issue 48's goal table on the actuated plant, measured from the recorded measured state (about 2 min).

Each case is a shipped scenario run through :func:`uvms.scenario.run_scenario`; every number is recomputed from
its ``trajectory.npz`` (the measured q) and ``actuation.npz``, never read from ``metrics.json``: distances with coal
on the model's collision shapes (the pipe as a coal cylinder; the stow's checked self pairs), the end-effector
error by Pinocchio's forward kinematics against the recorded desired point, the tilt from the base rotation.

    python benchmarks/actuated_goals.py            # the table
    python benchmarks/actuated_goals.py pipe stow  # only the cases whose name starts with these
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import coal
import numpy as np
import pinocchio as pin

from uvms.dynamics.thrusters.thrusters import thrusters_of
from uvms.model.collision import collision_geometry, collision_pairs
from uvms.scenario import run_scenario

SCENARIOS = Path(__file__).resolve().parents[1] / "scenarios"
ACTUATED = ["plant.type=hydrodynamic", "plant.thrusters=true", "plant.gravity=true"]
NO_FIGURES = ["outputs.figures=false"]
PIPE_RADIUS, PIPE_LENGTH = 0.06, 2.0
PIPE_POSE = pin.SE3(pin.rpy.rpyToMatrix(1.5707963, 0.0, 0.0), np.array([0.5, 0.0, -5.42]))


def shapes_at(robot, geometry, q):
    """[(name, coal shape, coal.Transform3s)] of every collision shape at q."""
    data = robot.model.createData()
    geometry_data = pin.GeometryData(geometry)
    pin.updateGeometryPlacements(robot.model, data, geometry, geometry_data, q)
    return [(item.name, item.geometry, coal.Transform3s(placement.rotation, placement.translation))
            for item, placement in zip(geometry.geometryObjects, geometry_data.oMg)]


def signed_distance(shape_a, pose_a, shape_b, pose_b) -> float:
    """coal's signed distance [m] of two placed shapes (negative: penetration depth)."""
    request, result = coal.DistanceRequest(), coal.DistanceResult()
    request.enable_signed_distance = True
    return float(coal.distance(shape_a, pose_a, shape_b, pose_b, request, result))


def pipe_distances(robot, q_series: np.ndarray) -> np.ndarray:
    """min over the robot's shapes of the distance to the pipe (T,) [m] at each recorded q."""
    geometry = collision_geometry(robot)
    pipe = coal.Cylinder(PIPE_RADIUS, PIPE_LENGTH)
    pipe_pose = coal.Transform3s(PIPE_POSE.rotation, PIPE_POSE.translation)
    return np.array([min(signed_distance(shape, pose, pipe, pipe_pose) for _, shape, pose in
                         shapes_at(robot, geometry, q)) for q in q_series])


def self_distances(robot, q_series: np.ndarray) -> np.ndarray:
    """min over the model's checked pairs (its SRDF) of the shapes' distance (T,) [m] at each recorded q."""
    geometry = collision_geometry(robot)
    pairs = collision_pairs(robot, geometry).pairs
    out = []
    for q in q_series:
        shapes = shapes_at(robot, geometry, q)
        out.append(min(signed_distance(shapes[a][1], shapes[a][2], shapes[b][1], shapes[b][2]) for a, b in pairs))
    return np.array(out)


def ee_errors(robot, trajectory: dict, frame: str = "ee") -> np.ndarray:
    """|FK(q) - desired| (T,) [m] from the recorded q and desired point."""
    points = np.array([robot.fk(q, frame).translation for q in trajectory["q"]])
    return np.linalg.norm(points - trajectory["desired_position"], axis=1)


def tilts(robot, q_series: np.ndarray) -> np.ndarray:
    """The angle between the vehicle's z axis and the world's (T,) [rad] at each recorded q."""
    return np.array([np.arccos(np.clip(robot.base_pose(q).rotation[2, 2], -1.0, 1.0)) for q in q_series])


def measure(case: str, name: str, overrides: list[str], root: Path) -> dict:
    """One row of the table: the recomputed numbers of the case."""
    from uvms import load

    folder = root / case
    run_scenario(SCENARIOS / f"{name}.toml", folder, [*NO_FIGURES, *overrides], progress=False)
    trajectory = dict(np.load(folder / "trajectory.npz"))
    actuation = dict(np.load(folder / "actuation.npz")) if (folder / "actuation.npz").exists() else {}
    robot = load(str(SCENARIOS.parent / "models" / "bluerov2_alpha5" / "uvms.urdf.xacro"))
    q = trajectory["q"]
    row = {"max_ee_error": float(ee_errors(robot, trajectory).max()), "max_tilt": float(tilts(robot, q).max())}
    if name.endswith("pipe"):
        row["min_pipe_distance"] = float(pipe_distances(robot, q[::2]).min())
    if name.endswith("stow"):
        row["min_self_distance"] = float(self_distances(robot, q[::2]).min())
    if "intervention" in name:
        row["min_seabed_clearance"] = float((q[:, 2] + 5.55).min())  # the vehicle's origin above z = -5.55 m
    if actuation:
        thrusters = thrusters_of(robot)
        bound = np.where(actuation["thrusts"] >= 0, thrusters.upper, -thrusters.lower)
        row["max_thrust_ratio"] = float(np.max(np.abs(actuation["thrusts"]) / bound))
    return row


CASES = {
    "pipe set_based": ("bluerov2_alpha5_pipe", ACTUATED),
    "pipe set_based current": ("bluerov2_alpha5_pipe", [*ACTUATED, "plant.current=[-0.3, 0, 0]"]),
    "pipe hqp": ("bluerov2_alpha5_pipe", [*ACTUATED, "solver.method=hqp"]),
    "pipe hqp current": ("bluerov2_alpha5_pipe", [*ACTUATED, "solver.method=hqp", "plant.current=[-0.3, 0, 0]"]),
    "stow set_based": ("bluerov2_alpha5_stow", ACTUATED),
    "stow hqp": ("bluerov2_alpha5_stow", [*ACTUATED, "solver.method=hqp"]),
    "intervention": ("bluerov2_alpha5_intervention", []),
    "moving task": ("bluerov2_alpha5_moving_task", []),
    "saturated current": ("bluerov2_alpha5_intervention_saturated_current", []),
}


def main(prefixes: list[str]) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        for case, (name, overrides) in CASES.items():
            if prefixes and not any(case.startswith(prefix) for prefix in prefixes):
                continue
            row = measure(case.replace(" ", "_"), name, overrides, Path(tmp))
            print(f"{case:24s} " + "  ".join(f"{key} {value:.4f}" for key, value in row.items()), flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
