"""The initial configuration (uvms.solvers.initial): initial.fixed_base keeps the vehicle's roll and pitch and
still reaches the target; its names are checked."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from uvms.errors import ScenarioError
from uvms.scenario import scenario_from_raw
from uvms.scenario.build import build

from conftest import shipped


def level_vehicle_scenario(fixed: list, method: str = "optimize") -> dict:
    """bluerov2_alpha5: q0 optimized to put the end effector on a pose reached with roll 0.05, pitch -0.03."""
    robot = shipped("bluerov2_alpha5")
    target = robot.fk(robot.configuration(base=np.array([0.2, 0.1, -0.1, 0.05, -0.03, 0.4]),
                                          arm=np.array([2.0, 1.2, 1.0, 2.5, 0.005])))
    raw = {"model": {"path": "bluerov2_alpha5"},
           "trajectory": {"type": "line", "start": target.translation.tolist(),
                          "orientation": pin.rpy.matrixToRpy(target.rotation).tolist(),
                          "end_offset": [0.0, 0.0, 0.05], "duration": 1.0},
           "initial": {"method": method, "base": [0.0, 0.0, 0.0, 0.05, -0.03, 0.0], "fixed_base": fixed},
           "simulation": {"dt": 0.05}}
    return scenario_from_raw(raw, "level.toml")


def test_initial_fixed_base_keeps_roll_and_pitch_and_still_reaches_the_target():
    robot = shipped("bluerov2_alpha5")
    free = build(level_vehicle_scenario([]))
    assert np.max(np.abs(robot.base_values(free.q0)[3:5] - [0.05, -0.03])) > 0.05  # it tilts when free to
    level = build(level_vehicle_scenario(["roll", "pitch"]))
    np.testing.assert_allclose(robot.base_values(level.q0)[3:5], [0.05, -0.03], atol=1e-9)
    assert level.initial_residual <= 1e-10
    target = level.task.target  # the start pose of the trajectory
    pose = robot.fk(level.q0, level.task.frame)
    np.testing.assert_allclose(pose.translation, target.translation, atol=1e-9)
    np.testing.assert_allclose(pose.rotation, target.rotation, atol=1e-9)


def test_initial_fixed_base_names_are_checked():
    with pytest.raises(ScenarioError, match="unknown vehicle coordinate 'rol'; close names: roll"):
        build(level_vehicle_scenario(["rol"]))
    with pytest.raises(ScenarioError, match="level.toml: initial.fixed_base .* needs initial.method = 'optimize'"):
        level_vehicle_scenario(["roll"], method="given")  # refused where the file is read
    with pytest.raises(ScenarioError, match=r"level.toml: initial.fixed_base must be a list of vehicle coordinate "
                                            r"names \(e.g. \['roll', 'pitch'\]\), got \[1\]"):
        level_vehicle_scenario([1])


def test_the_initial_configuration_does_not_depend_on_the_blas_threads():
    """hoang2011 sec. 2.3: SLSQP's q0 differed by 4e-16 (and a run by up to 3e-10) between 1 and 2 BLAS threads;
    it is solved on one thread, so a caller's thread setting (a sweep's worker: one) gives the same q0."""
    from threadpoolctl import threadpool_limits

    import uvms

    robot = shipped("hoang2011")
    task = uvms.FrameTask(robot, axes=("x", "y", "yaw"), orientation="euler", target=[0.0, -2.0, 0.0, 0.0, 0.0, 1.0])
    found = []
    for threads in (1, 2, 4):
        with threadpool_limits(limits=threads, user_api="blas"):
            found.append(uvms.solvers.initial_configuration(robot, task).q)
    assert all(np.array_equal(found[0], q) for q in found[1:])
