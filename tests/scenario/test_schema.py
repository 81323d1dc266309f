"""The scenario schema's ``[model] package_path`` (uvms.scenario.schema): folders of ROS packages, relative to the
scenario file, used by the run, recorded in its folder and read back by ``uvms view --result``."""

from __future__ import annotations

import json
import os
import shutil

import numpy as np
import pytest

from uvms.cli import main
from uvms.scenario import ScenarioError, read_run_record, read_scenario, run_scenario

from conftest import ROS_SHORT_RUN, ROS_WORKSPACE


@pytest.fixture
def scenario_folder(tmp_path, monkeypatch):
    """A folder holding the fixture's vehicle away from its workspace: it needs its packages named."""
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)
    shutil.copy(ROS_WORKSPACE / "fixture_vehicle_description" / "urdf" / "vehicle.urdf.xacro", tmp_path)
    return tmp_path


def write_scenario(folder, package_path: str = "") -> os.PathLike:
    path = folder / "short.toml"
    path.write_text(ROS_SHORT_RUN.format(package_path=package_path))
    return path


def test_a_scenario_names_its_package_folders_relative_to_its_own_folder(scenario_folder):
    relative = os.path.relpath(ROS_WORKSPACE, scenario_folder)
    assert relative.startswith("..")
    scenario = write_scenario(scenario_folder, f"package_path = [{json.dumps(relative)}]")
    assert read_scenario(scenario).model.package_path == (str(ROS_WORKSPACE),)
    result = run_scenario(scenario, out=scenario_folder / "out", progress=False)
    assert result.metrics["steps"] == 4 and result.metrics["max_position_error"] < 0.01
    arm_start = np.load(scenario_folder / "out" / "trajectory.npz")["q"][0, 7:]
    np.testing.assert_allclose(arm_start, [0.3, -0.7])  # the fixture's two arm joints, from the included package
    record = read_run_record(scenario_folder / "out")
    assert record.package_path == [str(ROS_WORKSPACE)]
    assert record.load().packages["fixture_arm_description"] == ROS_WORKSPACE / "fixture_arm"  # a replay finds them


def test_without_its_package_folders_a_scenario_fails_in_one_line(scenario_folder, capsys):
    scenario = write_scenario(scenario_folder)
    assert main(["run", str(scenario), "--out", str(scenario_folder / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no ROS package 'fixture_arm_description'" in err and "Traceback" not in err
    assert not (scenario_folder / "out").exists()


@pytest.mark.parametrize("value, words", [('"src"', "must be a list"), ("[1]", "must be a list of folders"),
                                          ('[""]', "must be a list of folders")])
def test_package_path_is_a_list_of_folder_names(scenario_folder, value, words):
    with pytest.raises(ScenarioError, match=words):
        read_scenario(write_scenario(scenario_folder, f"package_path = {value}"))
