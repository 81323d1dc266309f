"""The typed scenario spec (uvms.scenario.spec): a file read and checked once into frozen dataclasses, each key's
type, default, allowed values, bound and meaning declared once on its field."""

from __future__ import annotations

import dataclasses

import pytest

from uvms.errors import ScenarioError
from uvms.scenario import SECTIONS, ScenarioSpec, read_scenario
from uvms.scenario.spec import PhaseSpec, PlantSpec, SolverSpec, key_of


def test_a_scenario_reads_into_frozen_sections_with_defaults_and_overrides():
    spec = read_scenario("hoang2011_w1", ["solver.gain=2", "trajectory.normal=[0, 1, 0]"])
    assert isinstance(spec, ScenarioSpec) and spec.name == "hoang2011_w1" and spec.path.name == "hoang2011_w1.toml"
    assert isinstance(spec.solver, SolverSpec) and spec.solver.gain == 2 and spec.solver.method == "clik"
    assert spec.solver.weights == (1.0, 1.0, 1.0, 1.0, 1.0, 1.0)  # lists become tuples: nothing is shared or mutable
    assert spec.trajectory.normal == (0.0, 1.0, 0.0) and spec.plant.type == "kinematic"  # a default filled
    assert spec.trajectory.duration == 190 and spec.phases == () and spec.inequalities == ()
    with pytest.raises(dataclasses.FrozenInstanceError):
        spec.solver.gain = 3.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        spec.solver = spec.solver


@pytest.mark.parametrize("overrides, message", [
    (["plant.current=[0.1, 0, 0]"], "plant.current needs a dynamic plant"),
    (["plant.type=rigid", "solver.free_floating=true", "plant.gravity=true"], "plant.gravity needs type = "
                                                                                "'hydrodynamic'"),
    (["plant.type=rigid"], "plant.type = 'rigid' without thrusters leaves the vehicle passive"),
    (["vehicle_control.kp=50"], "vehicle_control.kp needs plant.thrusters = true"),
    (["excitation.seed=3"], "excitation.seed needs excitation.wrench"),
    (["trajectory.orientation=[]"], "initial.method = 'optimize' needs trajectory.start and trajectory.orientation"),
])
def test_sections_that_do_not_go_together_are_refused_where_the_file_is_read(overrides, message):
    """The plant's checks that need no model are the spec's (before, ``build`` found them after loading the
    model): reading the scenario refuses them, naming the file."""
    with pytest.raises(ScenarioError, match=f"hoang2011_w1.toml: {message}"):
        read_scenario("hoang2011_w1", overrides)


def test_a_sequence_scenario_has_phases_and_no_trajectory():
    spec = read_scenario("xiang2019_grip")
    assert spec.trajectory is None and all(isinstance(phase, PhaseSpec) for phase in spec.phases)
    assert spec.phases[0].duration > 0


def test_changed_names_the_keys_away_from_their_default():
    plant = PlantSpec(type="rigid", gravity=True, current=(0.0, 0.1, 0.0))
    assert plant.changed() == ["type", "gravity", "current"]
    assert plant.changed(("gravity", "damping")) == ["gravity"]
    assert PlantSpec().changed() == []


def test_every_key_is_declared_once_with_its_meaning_and_bound():
    for name, cls in SECTIONS.items():
        assert cls.ABOUT, name
        for key, spec in cls.keys().items():
            assert spec.doc.strip(), f"{name}.{key} has no meaning"
    dt = key_of("simulation.dt")
    assert dt.required and dt.bound.low == 0.0 and dt.bound.strict and "[s]" in dt.doc
    assert key_of("solver.damping").bound.what == "the DLS damping" and key_of("model.args.l1") is None
    assert key_of("phases.duration").required


def test_a_key_is_checked_where_the_spec_is_read_with_its_dotted_path(tmp_path):
    with pytest.raises(ScenarioError, match=r"solver.gain must be a number or a list, got 'fast'"):
        read_scenario("hoang2011_w1", ["solver.gain=fast"])
    with pytest.raises(ScenarioError, match=r"unknown key\(s\) plant.gravty; valid in \[plant\]: type, gjm"):
        read_scenario("hoang2011_w1", ["plant.gravty=true"])
    with pytest.raises(ScenarioError, match=r"simulation.dt = -0.1 is out of range: it is the integration step"):
        read_scenario("hoang2011_w1", ["simulation.dt=-0.1"])
