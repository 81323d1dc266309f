"""The papers' own claims under the papers' settings (hoang2011): error feedback, the printed q0."""

from __future__ import annotations

import numpy as np
import pytest

import uvms
from uvms.scenario import run_scenario

from conftest import SCENARIOS


def test_hoang2011_error_feedback_beats_the_open_loop_under_euler(tmp_path):
    errors = {}
    for name in ("hoang2011_w1_euler", "hoang2011_w1_euler_open_loop"):
        result = run_scenario(SCENARIOS / f"{name}.toml", out=tmp_path / name, progress=False,
                              overrides=["outputs.figures=false"])
        errors[name] = result.metrics["max_position_error"]
    assert errors["hoang2011_w1_euler"] * 10 < errors["hoang2011_w1_euler_open_loop"]
    assert 1e-3 < errors["hoang2011_w1_euler"] < 5e-3 and 3e-2 < errors["hoang2011_w1_euler_open_loop"] < 1e-1


def test_hoang2011_printed_q0_is_the_optimum_with_q1_below_three_quarter_pi():
    paper = np.array([-1.255, -3.213, 1.393, 1.178, 0.0, 0.0])  # printed, signs restored
    robot = uvms.load("hoang2011", args={"q1_max": 0.75 * np.pi})
    task = uvms.FrameTask(robot, axes=("x", "y", "yaw"), orientation="euler", target=[0, -2, 0, 0, 0, 1.0])
    initial = uvms.solvers.initial_configuration(robot, task)
    found = np.r_[robot.base_values(initial.q), robot.arm_configuration(initial.q)]
    assert np.abs(found - paper).max() < 1e-3 and found[3] <= 0.75 * np.pi
    stated = uvms.load("hoang2011")  # the printed limit 3*pi/2 gives q1 = 3*pi/4 instead
    other = uvms.solvers.initial_configuration(stated,
                                               uvms.FrameTask(stated, axes=("x", "y", "yaw"), orientation="euler",
                                                              target=[0, -2, 0, 0, 0, 1.0]))
    assert abs(stated.arm_configuration(other.q)[0] - 0.75 * np.pi) < 1e-6


def test_xiang2019_trajectories_fed_with_the_printed_tables_pass_through_them():
    from uvms.trajectory import ViaPointTrajectory

    points = np.deg2rad([[0, -10, -75, -90], [0, 25, 20, 10], [0, 5, -10, -30], [0, 5, -15, -35]]).T  # (4, 4)
    times = np.array([0.0, 10.0, 20.0, 30.0])
    velocities, accelerations = np.zeros((4, 4)), np.zeros((4, 4))
    velocities[1:3] = np.array([[-0.123, -0.131], [0.033, -0.025], [-0.016, -0.057], [-0.025, -0.065]]).T
    accelerations[1:3] = np.array([[-0.0377, 0.0402], [0.01005, 0.00755], [0.01005, 0.0176], [0.01255, 0.0201]]).T
    cubic = ViaPointTrajectory(points, times, degree=3, velocities=velocities)
    quintic = ViaPointTrajectory(points, times, degree=5, velocities=velocities, accelerations=accelerations)
    for trajectory in (cubic, quintic):
        at = trajectory(times)
        np.testing.assert_allclose(at.q, points, atol=1e-12)
        np.testing.assert_allclose(at.qd, velocities, atol=1e-12)
    np.testing.assert_allclose(quintic(times).qdd, accelerations, atol=1e-12)
    assert np.rad2deg(cubic.sample(0.01).q[:, 0].min()) < -91.5  # joint 1 overshoots the final -90 deg
    cubic = ViaPointTrajectory(points, times, 5).sample(0.01).qdd
    assert np.abs(quintic.sample(0.01).qdd).max() > 0.039 > np.abs(cubic).max()


def test_santos2006_classic_priority_meets_the_vehicle_task_the_robust_form_does_not(tmp_path):
    robot = uvms.load("santos2006")
    final = {}
    for name, overrides in (("robust", []), ("classic", ['solver.priority="classic"'])):
        result = run_scenario(SCENARIOS / "santos2006_task_priority.toml", out=tmp_path / name, progress=False,
                     overrides=["outputs.figures=false", *overrides])
        final[name] = (robot.base_values(result.simulation.q[-1])[2], result.metrics["vehicle_travel"])
    constraint = run_scenario(SCENARIOS / "santos2006_kinematic_constraint.toml", out=tmp_path / "kc", progress=False,
                     overrides=["outputs.figures=false"])
    assert abs(final["classic"][0] - 0.78) < 1e-3 and final["classic"][1] < 1e-9  # = the kinematic constraint
    assert final["robust"][0] < 0.7 and final["robust"][1] > 1.5  # the SR form only approximates the vehicle task
    assert constraint.metrics["vehicle_travel"] < 1e-12
    open_loop = run_scenario(SCENARIOS / "santos2006_kinematic_constraint_open_loop.toml", out=tmp_path / "open",
                    progress=False, overrides=["outputs.figures=false"])
    assert open_loop.metrics["max_position_error"] > 2 * constraint.metrics["max_position_error"]


def test_amundsen2018_variable_damping_acts_near_the_singular_configuration(tmp_path):
    result = run_scenario(SCENARIOS / "amundsen2018_near_singular.toml", out=tmp_path / "damped", progress=False,
                 overrides=["outputs.figures=false"])
    metrics = result.metrics
    assert metrics["min_sigma_min"] < 0.05 / 10 and metrics["max_damping"] > 0.04  # eq. 6 active
    assert metrics["max_joint_rate"] < 0.1  # rad/s: the damping keeps the rates bounded
    with pytest.raises(uvms.errors.NumericalError, match="diverged"):  # without damping the rates blow up
        run_scenario(SCENARIOS / "amundsen2018_near_singular.toml", out=tmp_path / "undamped", progress=False,
            overrides=["outputs.figures=false", "solver.damping_max=0.0"])
