"""An actuated vehicle in scenarios (uvms.scenario.actuated): plant.thrusters, [vehicle_control], the metrics, files
and checks.

The shipped scenarios: bluerov2_alpha5_station_current (0.3 m/s current, the jaws held, coordinated) and
bluerov2_alpha5_station_saturated (1.0 m/s: the thrusters saturate).
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from uvms.errors import ScenarioError
from uvms.scenario import run_scenario

from conftest import NO_FIGURES, SCENARIOS

CURRENT = SCENARIOS / "bluerov2_alpha5_station_current.toml"


@pytest.fixture(scope="module")
def current_runs(tmp_path_factory) -> dict:
    root = tmp_path_factory.mktemp("station")
    return {coordination: run_scenario(CURRENT, root / str(coordination),
                              [f"vehicle_control.coordination={str(coordination).lower()}"], progress=False)
            for coordination in (True, False)}


def test_coordination_holds_the_jaws_closer_in_a_current(current_runs):
    coordinated, plain = current_runs[True].metrics, current_runs[False].metrics
    assert coordinated["coordination"] is True and plain["coordination"] is False
    # the vehicle drifts the same (the arm's reaction is small), the arm takes it up only when coordinated
    assert coordinated["vehicle_position_error"] == pytest.approx(plain["vehicle_position_error"], rel=0.05)
    assert 0.01 < coordinated["vehicle_position_error"] < 0.08  # measured 0.018 m (0.048 without the observer)
    assert coordinated["final_vehicle_position_error"] < 2e-3  # the PI integral takes up the current
    assert coordinated["max_position_error"] < 0.5 * plain["max_position_error"]  # 0.0196 vs 0.0592 m (no observer)
    assert coordinated["rms_position_error"] < 0.3 * plain["rms_position_error"]  # 0.0058 vs 0.0293 m (no observer)
    for metrics in (coordinated, plain):
        assert 0.1 < metrics["max_thrust_ratio"] < 0.3 and metrics["saturated_time_fraction"] == 0.0
        assert metrics["thruster_energy"] > 0.5 and len(metrics["thrusters"]) == 8
        assert metrics["current"] == [-0.3, 0.0, 0.0]


def test_an_actuated_run_folder(current_runs):
    result = current_runs[True]
    names = {path.name for path in result.files}
    assert {"actuation.npz", "thrusters.png", "station.png", "trajectory.csv", "metrics.json"} <= names
    saved = np.load(result.files[[path.name for path in result.files].index("actuation.npz")])
    assert saved["thrusts"].shape == (601, 8)
    assert np.abs(saved["thrusts"]).max() <= 51.5  # inside the T200's limits
    assert np.max(saved["ee_point_error"]) == pytest.approx(result.metrics["max_position_error"], rel=1e-9)
    header = (result.files[[path.name for path in result.files].index("trajectory.csv")]).read_text().split("\n")[0]
    assert "position_error" in header and "sigma_min" not in header  # no one inverse to report: no column


def test_a_current_beyond_the_thrusters_saturates_them_and_surge_gives_way(tmp_path):
    metrics = run_scenario("bluerov2_alpha5_station_saturated", tmp_path / "s", NO_FIGURES, progress=False).metrics
    assert metrics["max_thrust_ratio"] == pytest.approx(1.0, abs=1e-9) and metrics["max_thrust_ratio"] <= 1.0
    assert metrics["saturated_time_fraction"] > 0.8  # measured 0.905
    assert metrics["final_vehicle_position_error"] > 0.5  # measured 0.87 m downstream
    assert metrics["max_vehicle_tilt"] < 0.1  # measured 0.070 rad: the attitude kept (priority)
    assert not metrics["verdict"]["within_tolerance"]
    assert any("position error" in warning for warning in metrics["verdict"]["warnings"])


@pytest.mark.parametrize("overrides, message", [
    (["plant.type=kinematic"], "needs a dynamic plant"),
    (["plant.type=rigid", "plant.gravity=false", "plant.current=[]"], "thrusters = true needs "
                                                                      "plant.type = 'hydrodynamic'"),
    (["solver.free_floating=true"], "leaves the vehicle passive"),
    (["solver.gain=[1.0, 1.0, 1.0]"], "solver.gain is one number"),
    (['vehicle_control.priorities=[["surge"]]'], "groups of wrench axes among x, y, z, roll, pitch, yaw"),
    (["plant.thrusters=false"], "vehicle_control.kp needs plant.thrusters = true"),
])
def test_what_station_keeping_does_not_do_is_refused(tmp_path, overrides, message):
    extra = ["vehicle_control.kp=50"] if overrides == ["plant.thrusters=false"] else []
    with pytest.raises(ScenarioError, match=message.replace("(", r"\(").replace("[", r"\[")):
        run_scenario(CURRENT, tmp_path / "o", [*NO_FIGURES, *overrides, *extra], progress=False)
    assert not (tmp_path / "o").exists()


def test_a_vehicle_without_thrusters_is_told_where_they_go(tmp_path):
    text = CURRENT.read_text().replace("bluerov2_alpha5/uvms.urdf.xacro", "amundsen2018/usm.urdf.xacro")
    text = text.replace("arm = [3.0, 1.8, 1.8, 1.0, 0.0]", "arm = [0.3, 0.3, -0.3, -0.3, 0.3, 0.3, -0.3, -0.3]")
    path = tmp_path / "s.toml"
    path.write_text(text.replace('path = "../models', f'path = "{SCENARIOS.parent}/models'))
    with pytest.raises(ScenarioError, match="no thrusters.*thrusters.yaml"):
        run_scenario(path, tmp_path / "o", NO_FIGURES, progress=False)


def test_the_bag_of_an_actuated_run_has_the_thrusts_and_the_body_wrench(tmp_path):
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_typestore

    result = run_scenario(CURRENT, tmp_path / "b", [*NO_FIGURES, "outputs.bag=true", "trajectory.duration=0.5"],
                          progress=False)
    typestore, series = get_typestore(Stores.ROS2_HUMBLE), {}
    with Reader(tmp_path / "b" / "bag") as reader:
        for connection, _, raw in reader.messages():
            series.setdefault(connection.topic, []).append(typestore.deserialize_cdr(raw, connection.msgtype))
    saved = np.load(tmp_path / "b" / "actuation.npz")
    thrust_3 = np.array([message.data for message in series["/thrusters/thruster_3/thrust"]])
    assert np.array_equal(thrust_3, saved["thrusts"][:, 2]) and len(thrust_3) == 51
    wrench = np.array([[m.wrench.force.x, m.wrench.force.y, m.wrench.force.z, m.wrench.torque.x, m.wrench.torque.y,
                        m.wrench.torque.z] for m in series["/body_wrench"]])
    assert np.array_equal(wrench, saved["body_wrench"]) and series["/body_wrench"][0].header.frame_id == "base_link"
    assert result.metrics["bag"]["topics"]["/thrusters/thruster_8/thrust"] == 51


LINE = ["trajectory.type=line", "trajectory.end_offset=[1.0, 0.0, 0.0]", "trajectory.duration=6.0",
        "trajectory.accel_time=1.5", "simulation.duration=7.0"]


@pytest.mark.parametrize("method", ["clik", "kinematic_constraint"])
def test_a_vehicle_without_an_arm_carries_its_task(tmp_path, method):
    """A line of 1.0 m for the base link of a vehicle without an arm, in the 0.3 m/s current from ahead: the
    vehicle carries the whole task with the vehicle given to the task (CLIK, the pose objective above the task):
    measured 1.026 m of travel, 6.3 mm of final error (before: 4.7e-3 m of travel, 1.0 m of error)."""
    from test_runs import armless_vehicle

    overrides = [*NO_FIGURES, *LINE, f"solver.method={method}",
                 *(["solver.damping=0.0"] if method == "kinematic_constraint" else [])]
    metrics = run_scenario(armless_vehicle(tmp_path), tmp_path / "out", overrides, progress=False).metrics
    assert 0.95 < metrics["vehicle_travel"] < 1.05 and metrics["arm_travel"] == 0.0
    assert metrics["final_position_error"] < 0.01 and metrics["max_position_error"] < 0.02
    assert metrics["max_vehicle_tilt"] < 0.01 and metrics["verdict"]["ok"]


def test_the_recorder_reads_the_chains_rows_at_the_measured_q():
    """The intervention's chain (set-based, three objectives above the jaws): after a step's command the objectives'
    rows the solves evaluated at the measured q are the recorder's values and activations, bit for bit, read
    without evaluating an objective again; at another q, or with no step yet, there are none and the recorder
    evaluates them itself."""
    import pinocchio as pin

    from uvms.dynamics.plant.command import State
    from uvms.scenario.actuated import ActuatedObjectives
    from uvms.scenario.build import build
    from uvms.scenario.schema import read_scenario

    setup = build(read_scenario(SCENARIOS / "bluerov2_alpha5_intervention.toml", ["outputs.figures=false"]))
    actuation, robot = setup.actuation, setup.robot
    kinematic = actuation.controller.kinematic
    reading = ActuatedObjectives(robot, actuation.inequalities, kinematic)
    evaluating = ActuatedObjectives(robot, actuation.inequalities)
    rng = np.random.default_rng(5)
    q = pin.integrate(robot.model, setup.q0, 0.1 * rng.normal(size=robot.nv))
    v = 0.05 * rng.normal(size=robot.nv)
    state = State(q, v, np.zeros(8), np.zeros(0))
    assert kinematic.objective_rows(q) is None  # no step yet
    actuation.controller.reset(state, 0.0)
    command = actuation.controller.command(state, 0.5)
    rows = kinematic.objective_rows(q)
    assert rows is not None and kinematic.objective_rows(pin.integrate(robot.model, q, 1e-9 * v)) is None
    evaluated = []
    for objective in actuation.inequalities.objectives:  # an objective evaluated again would be counted
        objective.value = lambda state, objective=objective: evaluated.append(objective.name) or \
            type(objective).value(objective, state)
    sample = SimpleNamespace(rate=(v, None), command=command)
    read = reading(0.5, q, None, sample)
    assert evaluated == []
    alone = evaluating(0.5, q, None, sample)
    assert len(evaluated) == 3
    for name in ("objective_value", "objective_activation", "objective_active", "objective_pair"):
        first, second = np.asarray(read[name]), np.asarray(alone[name])  # as the loop stacks a row's values
        assert first.dtype == second.dtype and first.tobytes() == second.tobytes(), name
    # the tilt past its limit, the seabed clearance in its band: activations 1 and between 0 and 1
    assert alone["objective_active"] == [False, True, True]
    assert alone["objective_activation"][4] == 1.0 and 0.5 < alone["objective_activation"][5] < 1.0
    assert read["speed_ratio"] == alone["speed_ratio"] == 0.0  # no speed limit
