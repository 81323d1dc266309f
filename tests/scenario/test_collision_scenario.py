"""Collision objectives from a scenario file: ``self_collision`` and a mesh ``obstacle`` keep every recorded
configuration clear (distances recomputed from the trajectory, not read from metrics) where CLIK drives the jaw
through the vehicle; the files a scenario names stay inside its folder."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

import uvms
from uvms.errors import ScenarioError
from uvms.model.collision import candidate_pairs, collision_geometry
from uvms.model.distances import PairDistances
from uvms.robot.configuration import Configuration
from uvms.tasks.objectives import Obstacle

FIXTURES = Path(__file__).parents[1] / "fixtures" / "collision"
SCENARIO = FIXTURES / "box_arm_fold.toml"


def closest(robot, run):
    """(smallest self distance, smallest distance to the rock) [m] over the recorded configurations."""
    geometry = collision_geometry(robot)
    pairs = PairDistances(robot.model, geometry, candidate_pairs(robot, geometry).pairs)
    rock = Obstacle(robot, "mesh", mesh=FIXTURES / "rock.stl", position=[0.6, 0.22, 0.1])
    states = [Configuration(robot, q) for q in run.simulation.q]
    return (min(pairs.evaluate(state).distance.min() for state in states),
            min(rock.value(state).min() for state in states))


@pytest.mark.parametrize("method", ["set_based", "hqp"])
def test_the_jaw_folds_under_the_bow_clear_of_the_vehicle_and_the_rock(tmp_path, method):
    run = uvms.run_scenario(SCENARIO, tmp_path / "run", overrides=[f"solver.method={method}"], progress=False)
    self_distance, rock_distance = closest(run.setup.robot, run)
    assert self_distance >= 0.02 - 1e-4 and rock_distance >= 0.02 - 1e-4
    assert rock_distance < 0.02 + 0.05  # the rock was in the way: within its band
    assert run.metrics["final_position_error"] < 1e-3


def test_clik_on_the_same_path_drives_the_jaw_through_the_vehicle(tmp_path):
    run = uvms.run_scenario(SCENARIO, tmp_path / "run", overrides=["solver.method=clik"], progress=False)
    assert closest(run.setup.robot, run)[0] < -0.04
    assert run.metrics["inequalities_enforced"] is False


@pytest.mark.parametrize(("mesh", "words"), [
    ("../rock.stl", "leads out of the scenario's folder"),
    ("/etc/hostname", "must be a file path relative to the scenario's folder"),
    ("link.stl", "leads out of the scenario's folder"),  # a symbolic link to a file outside
    ("boulder.stl", "is not a file in the scenario's folder"),
])
def test_a_scenario_reads_only_the_files_inside_its_folder(tmp_path, mesh, words):
    folder = tmp_path / "scenario"
    folder.mkdir()
    for name in ("box_arm.urdf", "rock.stl"):
        shutil.copy(FIXTURES / name, folder / name)
    shutil.copy(FIXTURES / "rock.stl", tmp_path / "rock.stl")
    (folder / "link.stl").symlink_to(tmp_path / "rock.stl")
    scenario = folder / "fold.toml"
    scenario.write_text(SCENARIO.read_text().replace('mesh = "rock.stl"', f'mesh = "{mesh}"'))
    with pytest.raises(ScenarioError, match=rf"inequalities\[1\]\.mesh.*{words}"):
        uvms.scenario.schema.read_scenario(scenario)


def test_the_mesh_and_srdf_of_a_scenario_resolve_beside_it(tmp_path):
    scenario = uvms.scenario.schema.read_scenario(SCENARIO)
    assert scenario.inequalities[1].keys["mesh"] == str((FIXTURES / "rock.stl").resolve())
    folder = tmp_path / "scenario"
    shutil.copytree(FIXTURES, folder)
    (folder / "box_arm.srdf").write_text('<robot><disable_collisions link1="base_link" link2="jaw"/></robot>')
    text = SCENARIO.read_text().replace('pairs = "all"', 'srdf = "box_arm.srdf"')
    (folder / "fold.toml").write_text(text)
    scenario = uvms.scenario.schema.read_scenario(folder / "fold.toml")
    assert scenario.inequalities[0].keys["srdf"] == str((folder / "box_arm.srdf").resolve())
    robot = uvms.load(folder / "box_arm.urdf", base="floating")
    built = uvms.tasks.objectives.inequalities_from_table(robot, scenario.inequalities[0].table)[0]
    assert ("base_link", "jaw") not in built.links and built.disabled[("base_link", "jaw")] == "srdf"
    assert np.isfinite(built.value(Configuration(robot, robot.neutral()))).all()


# ------------------------------------------------------------------ the shipped BlueROV2 + Alpha 5 scenarios
SCENARIOS = Path(__file__).parents[2] / "scenarios"


def recorded_distances(run, table: dict) -> np.ndarray:
    """(N, dim) the distances of an ``[[inequalities]]`` table's objective, built afresh, at every recorded q [m]."""
    objective = uvms.tasks.objectives.inequalities_from_table(run.setup.robot, table)[0]
    return np.array([objective.value(Configuration(run.setup.robot, q)) for q in run.simulation.q])


def test_the_jaws_tuck_under_the_bow_clear_of_the_vehicle_where_straight_clik_puts_them_in_it(tmp_path):
    scenario = SCENARIOS / "bluerov2_alpha5_stow.toml"
    table = uvms.scenario.schema.read_scenario(scenario).inequalities[1].table
    run = uvms.run_scenario(scenario, tmp_path / "stow", overrides=["outputs.figures=false"], progress=False)
    distances = recorded_distances(run, table)
    assert distances.min() >= table["min"] - 1e-4  # every recorded step, every row (the 6 nearest pairs)
    assert distances.min() == pytest.approx(run.metrics["min_self_distance"], abs=1e-12)
    assert run.metrics["verdict"]["ok"] and run.metrics["final_position_error"] < 1e-4
    assert run.simulation.q[-1, 2] - run.simulation.q[0, 2] > 0.05  # the vehicle rose to make room
    entry = run.metrics["inequalities"]["self_collision"]
    assert entry["closest"]["distance"] == run.metrics["min_self_distance"]
    assert list(entry["pairs_active"]) == ["alpha_m2_joint_link / alpha_m1_link"]  # the wrist off the upper arm
    jaws = uvms.tasks.objectives.SelfCollision(run.setup.robot, pairs=[["base_link", "alpha_jaw_link"]])
    assert min(jaws.value(Configuration(run.setup.robot, q)).min() for q in run.simulation.q) > 0.05  # so the jaws
    # never turn up into the bottom plate
    assert all(0.0 < fraction <= entry["active_fraction"] for fraction in entry["pairs_active"].values())
    clik = uvms.run_scenario(scenario, tmp_path / "clik", overrides=["outputs.figures=false", "solver.method=clik"],
                             progress=False)
    assert recorded_distances(clik, table).min() < -0.01  # the jaws' box inside the plate, within the joint limits
    assert clik.metrics["max_joint_limit_violation"] == 0.0 and not clik.metrics["verdict"]["ok"]


def test_the_jaws_slide_along_the_pipe_instead_of_into_it(tmp_path):
    scenario = SCENARIOS / "bluerov2_alpha5_pipe.toml"
    table = uvms.scenario.schema.read_scenario(scenario).inequalities[1].table
    run = uvms.run_scenario(scenario, tmp_path / "pipe", overrides=["outputs.figures=false"], progress=False)
    distances = recorded_distances(run, table)
    assert distances.min() >= table["min"] - 1e-4
    assert distances.min() < table["min"] + table["band"]  # the pipe was in the way
    assert run.metrics["inequalities"]["pipe"]["closest"]["pair"] == "pipe / alpha_jaw_link"
    assert 0.02 < run.metrics["final_position_error"] < 0.05  # the line's end is inside the pipe: the task yields
    clik = uvms.run_scenario(scenario, tmp_path / "clik", overrides=["outputs.figures=false", "solver.method=clik"],
                             progress=False)
    assert recorded_distances(clik, table).min() < -0.02  # the jaws 2.7 cm into the pipe
