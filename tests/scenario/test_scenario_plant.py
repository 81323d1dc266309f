"""A scenario's dynamic plant (Plant.from_settings of [plant]): plant.hydrodynamics loads a hydrodynamics YAML from the
scenario's folder (e.g. what uvms identify wrote) in place of the model's own."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from uvms.dynamics.hydro.hydrodynamics import hydrodynamics_of
from uvms.dynamics.hydro.writer import hydrodynamics_yaml_text
from uvms.errors import ScenarioError
from uvms.scenario.build import build
from uvms.scenario.schema import read_scenario

from conftest import ROOT, SCENARIOS

STATION = SCENARIOS / "bluerov2_alpha5_station_current.toml"


def station_in(folder: Path) -> Path:
    """The shipped station-keeping scenario in ``folder``, its model path absolute."""
    path = folder / "station.toml"
    path.write_text(STATION.read_text().replace('"../models/', f'"{ROOT}/models/'))
    return path


def test_plant_hydrodynamics_replaces_the_models_own(tmp_path):
    scenario = station_in(tmp_path)
    robot = build(read_scenario(scenario)).robot
    model = hydrodynamics_of(robot)
    link = model.links["base_link"]
    heavier = dataclasses.replace(link, added_mass=2.0 * link.added_mass,
                                  quadratic_damping=link.quadratic_damping + 7.0)
    (tmp_path / "mine.yaml").write_text(hydrodynamics_yaml_text(
        dataclasses.replace(model, links={**model.links, "base_link": heavier})))
    setup = build(read_scenario(scenario, ["plant.hydrodynamics='mine.yaml'"]))
    loaded = setup.plant.hydro.links["base_link"]
    np.testing.assert_array_equal(loaded.added_mass, 2.0 * link.added_mass)
    np.testing.assert_array_equal(loaded.quadratic_damping, link.quadratic_damping + 7.0)
    assert setup.plant.hydro.source == str(tmp_path / "mine.yaml")


@pytest.mark.parametrize("value, message", [
    ("'../elsewhere.yaml'", "leads out of the scenario's folder"),
    ("'missing.yaml'", "is not a file in the scenario's folder"),
    ("'bad.yaml'", "plant.hydrodynamics: .*bad.yaml.*no_such_link"),
])
def test_a_bad_plant_hydrodynamics_is_refused(tmp_path, value, message):
    scenario = station_in(tmp_path)
    (tmp_path.parent / "elsewhere.yaml").write_text("links: {}\n")
    (tmp_path / "bad.yaml").write_text("links:\n  no_such_link:\n    volume: 0.01\n")
    with pytest.raises(ScenarioError, match=message):
        build(read_scenario(scenario, [f"plant.hydrodynamics={value}"]))


@pytest.mark.parametrize("plant, message", [("rigid", "plant.hydrodynamics needs type = 'hydrodynamic'"),
                                            ("kinematic", "plant.hydrodynamics needs a dynamic plant")])
def test_plant_hydrodynamics_needs_the_hydrodynamic_plant(tmp_path, plant, message):
    scenario = tmp_path / "closed_loop.toml"
    text = (SCENARIOS / "amundsen2018_hydro_closed_loop.toml").read_text().replace('"../models/', f'"{ROOT}/models/')
    plant_section = text[text.index("[plant]"):text.index("[simulation]")]
    scenario.write_text(text.replace(plant_section, f'[plant]\ntype = "{plant}"\nhydrodynamics = "mine.yaml"\n\n'))
    (tmp_path / "mine.yaml").write_text("links: {}\n")
    overrides = ["solver.free_floating=false"] if plant == "kinematic" else []
    with pytest.raises(ScenarioError, match=message):
        build(read_scenario(scenario, overrides))


def test_the_hydrodynamics_yaml_is_an_input_of_the_run_and_of_watch(tmp_path):
    """An identified YAML read from a previous output folder: a run into that folder would replace the file it
    reads, so it is refused before anything is written; --watch reruns when the YAML changes."""
    from uvms.errors import RunFolderError
    from uvms.io import outputs
    from uvms.scenario.runs import run_scenario
    from uvms.scenario.watch import WatchedFiles

    scenario = station_in(tmp_path)
    robot = build(read_scenario(scenario)).robot
    identified = tmp_path / "identified"
    with outputs.run_folder(identified) as folder:  # what `uvms identify --out identified` leaves
        (folder / "hydrodynamics.yaml").write_text(hydrodynamics_yaml_text(hydrodynamics_of(robot)))
    text = scenario.read_text()
    scenario.write_text(text.replace("[plant]", "[plant]\nhydrodynamics = \"identified/hydrodynamics.yaml\"", 1))
    assert "identified/hydrodynamics.yaml" in scenario.read_text()
    before = sorted(path.name for path in identified.iterdir())
    with pytest.raises(RunFolderError, match="hydrodynamics.yaml"):
        run_scenario(scenario, out=identified, progress=False)
    assert sorted(path.name for path in identified.iterdir()) == before
    watched = WatchedFiles.of(scenario=scenario)
    assert watched.wants(identified / "hydrodynamics.yaml") and not watched.wants(identified / "other.yaml")
