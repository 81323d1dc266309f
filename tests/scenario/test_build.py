"""Building a scenario (uvms.scenario.build): solver.weights of the wrong size name the key and what it needs."""

from __future__ import annotations

import numpy as np
import pytest

import uvms
from conftest import NO_FIGURES, shipped
from uvms.errors import ScenarioError, SolverInputError
from uvms.scenario import run_scenario


def test_free_floating_weights_of_size_nv_name_the_key_and_the_arm_joints(tmp_path):
    for name, extra in (("hoang2011_gjm", []), ("hoang2011_w1_euler", ["solver.free_floating=true"])):
        with pytest.raises(ScenarioError) as caught:
            run_scenario(name, out=tmp_path / name, overrides=[*NO_FIGURES, *extra, "solver.weights=[1, 1, 1, 1, 1, 1]"])
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
