"""Building a scenario (uvms.scenario.build): solver.weights of the wrong size name the key and what it needs."""

from __future__ import annotations

import numpy as np
import pytest

import uvms
from uvms.errors import ScenarioError, SolverInputError
from uvms.scenario import run_scenario
from uvms.scenario.record import read_run_record

from conftest import NO_FIGURES, ROOT, shipped


def test_free_floating_weights_of_size_nv_name_the_key_and_the_arm_joints(tmp_path):
    for name, extra in (("hoang2011_gjm", []), ("hoang2011_w1_euler", ["solver.free_floating=true"])):
        with pytest.raises(ScenarioError) as caught:
            run_scenario(name, out=tmp_path / name,
                         overrides=[*NO_FIGURES, *extra, "solver.weights=[1, 1, 1, 1, 1, 1]"])
        message = str(caught.value)
        assert "solver.weights has 6 numbers, hoang2011_uvms needs 3" in message
        assert "free-floating (generalized-Jacobian) weights cover the arm joints only" in message
    with pytest.raises(ScenarioError, match=r"needs 6: one per velocity coordinate: the vehicle \(x, y, yaw\)"):
        run_scenario("hoang2011_w1_euler", out=tmp_path / "k", overrides=[*NO_FIGURES, "solver.weights=[1, 1, 1]"])
    robot = shipped("hoang2011")
    task = uvms.FrameTask(robot, axes=["x", "y"])
    task.set_target(np.zeros(6))
    with pytest.raises(SolverInputError, match=r"W must be \(3,\).*arm joints only"):
        uvms.CLIKSolver(robot, task, weights=np.ones(robot.nv), free_floating=True)


IDIOMS_SCENARIO = """
[model]
path = "{model}"
{arm_joints}
[task]
axes = ["x", "y", "z"]

[trajectory]
type = "line"
end_offset = [0.05, 0.0, 0.0]
duration = 0.5

[initial]
arm = {arm}

[solver]
method = "clik"

[simulation]
dt = 0.05
"""


def idioms_scenario(tmp_path, arm: str, arm_joints: str = ""):
    path = tmp_path / "idioms.toml"
    path.write_text(IDIOMS_SCENARIO.format(model=ROOT / "tests" / "fixtures" / "joints" / "rov_idioms.urdf", arm=arm,
                                           arm_joints=arm_joints))
    return path


def test_initial_arm_as_a_table_starts_the_joints_left_out_at_zero(tmp_path):
    run = run_scenario(idioms_scenario(tmp_path, "{j2 = 0.3, j6 = 0.5, finger_a = 0.4}"), out=tmp_path / "out",
                       overrides=NO_FIGURES)
    robot = run.setup.robot
    assert robot.arm_joint_names == ["j1", "j2", "j3", "j4", "j5", "j6", "finger_a"]  # propellers, sensors frozen
    np.testing.assert_array_equal(robot.arm_configuration(run.simulation.q[0]), [0, 0.3, 0, 0, 0, 0.5, 0.4])
    assert run.metrics["max_position_error"] < 0.01  # the 7-DOF arm follows the line
    as_list = run_scenario(idioms_scenario(tmp_path, "[0, 0.3, 0, 0, 0, 0.5, 0.4]"), out=tmp_path / "list",
                           overrides=NO_FIGURES)
    np.testing.assert_array_equal(as_list.simulation.q, run.simulation.q)
    with pytest.raises(ScenarioError, match=r"initial.base/initial.arm: unknown arm joint 'j7'; close names: j6, j5"):
        run_scenario(idioms_scenario(tmp_path, "{j7 = 0.1}"), out=tmp_path / "bad", overrides=NO_FIGURES)
    with pytest.raises(ScenarioError, match="initial.arm.j1 must be a number"):
        run_scenario(idioms_scenario(tmp_path, '{j1 = "up"}'), out=tmp_path / "bad", overrides=NO_FIGURES)


def test_model_arm_joints_freezes_the_others_and_the_run_records_it(tmp_path):
    path = idioms_scenario(tmp_path, "{j6 = 0.5}", 'arm_joints = ["j1", "j2", "j3", "j6"]')
    run = run_scenario(path, out=tmp_path / "out", overrides=NO_FIGURES)
    assert run.setup.robot.arm_joint_names == ["j1", "j2", "j3", "j6"]
    assert run.metrics["model"]["arm_joints"] == ["j1", "j2", "j3", "j6"]
    replayed = read_run_record(tmp_path / "out").load()  # what `uvms view --result` draws the run on
    assert replayed.arm_joint_names == ["j1", "j2", "j3", "j6"] and replayed.nq == run.setup.robot.nq
    with pytest.raises(uvms.errors.NameNotFound, match="arm_joints: unknown arm joint 'j9'"):
        run_scenario(path, out=tmp_path / "bad", overrides=[*NO_FIGURES, 'model.arm_joints=["j9"]'])
