"""The excitation as a scenario ([excitation], uvms.scenario.excitation.scenario_excitation) and the round trip:
a run with the true model -> its bag -> uvms identify -> the same scenario rerun with the identified YAML
(plant.hydrodynamics) reproduces the logged velocities."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from uvms.control import State
from uvms.dynamics.hydro.hydrodynamics import hydrodynamics_of
from uvms.dynamics.hydro.writer import hydrodynamics_yaml_text
from uvms.dynamics.identification.identify import identify
from uvms.errors import ScenarioError
from uvms.scenario.bags.reader import read_bag
from uvms.scenario.build import build
from uvms.scenario.excitation import log_of_run, multisine
from uvms.scenario.runs import run_scenario
from uvms.scenario.schema import read_scenario

from conftest import NO_FIGURES, ROOT, SCENARIOS

EXCITATION = SCENARIOS / "bluerov2_excitation.toml"
#: A shorter excitation for the tests: 40 s, 4 sines per axis up to 0.5 Hz.
SHORT = ["trajectory.duration=40", "excitation.components=4", *NO_FIGURES]


def scenario_copy(folder: Path) -> Path:
    """The shipped excitation scenario in ``folder`` (its model path absolute), so YAML files can sit beside it."""
    text = EXCITATION.read_text().replace('"../models/', f'"{ROOT}/models/')
    path = folder / "excitation.toml"
    path.write_text(text)
    return path


def twist_rms(rerun_twist: np.ndarray, logged_twist: np.ndarray) -> np.ndarray:
    """RMS (6,) of the twist difference, relative to the logged twist's RMS per axis."""
    return np.sqrt(np.mean((rerun_twist - logged_twist) ** 2, axis=0) / np.mean(logged_twist ** 2, axis=0))


def test_a_run_with_the_identified_yaml_reproduces_the_logged_velocities(tmp_path):
    scenario = scenario_copy(tmp_path)
    truth = run_scenario(scenario, tmp_path / "truth", [*SHORT, "outputs.bag=true"], progress=False)
    assert truth.metrics["max_thrust_ratio"] <= 1.0 and truth.metrics["saturated_time_fraction"] == 0.0
    log = read_bag(tmp_path / "truth" / "bag")  # the bag as `uvms run --bag` wrote it, default topics
    robot = truth.setup.robot
    model = hydrodynamics_of(robot)
    true_link = model.links["base_link"]
    wrong = dataclasses.replace(true_link, added_mass=1.4 * true_link.added_mass,
                                linear_damping=0.6 * true_link.linear_damping + 1.0,
                                quadratic_damping=1.5 * true_link.quadratic_damping)
    (tmp_path / "prior.yaml").write_text(hydrodynamics_yaml_text(
        dataclasses.replace(model, links={**model.links, "base_link": wrong})))
    result = identify(robot, log, hydro=hydrodynamics_of(robot, tmp_path / "prior.yaml"))
    (tmp_path / "identified.yaml").write_text(hydrodynamics_yaml_text(result.hydro))
    errors = {}
    for name in ("identified", "prior"):
        rerun = run_scenario(scenario, tmp_path / name, [*SHORT, f"plant.hydrodynamics='{name}.yaml'"], progress=False)
        again = log_of_run(robot, rerun.simulation)
        np.testing.assert_allclose(again.t, log.t, atol=1e-9)
        errors[name] = twist_rms(again.twist, log.twist)
    # measured: identified 0.07-0.25 % of each axis's RMS velocity, the prior (1.4 M_A, 0.6 D_l + 1, 1.5 D_q) 13-47 %
    assert np.all(errors["identified"] < 0.01), errors["identified"]
    assert np.all(errors["prior"] > 0.1), errors["prior"]


def test_the_excitation_scenario_drives_the_thrusters_with_the_multisine(tmp_path):
    scenario = read_scenario(scenario_copy(tmp_path), ["excitation.arm=[0.4, 0.3, 0.3, 0.4, 0.0]", "excitation.seed=3"])
    setup = build(scenario)
    control = setup.actuation.controller
    wrench = multisine(np.array(scenario.excitation.wrench), components=8, seed=3)
    q, v = setup.q0, np.zeros(setup.robot.nv)
    command = control.command(State(q, v, np.zeros(8)), 12.3)
    # the commanded thrusts give the multi-sine's wrench through the allocation matrix (B B^+ = I: 8 thrusters)
    np.testing.assert_allclose(control.actuated.matrix @ command.thrust, wrench(12.3), atol=1e-9)
    omega = 2 * np.pi * (1 + 0.37 * np.arange(5)) / 20.0
    np.testing.assert_allclose(command.arm, [0.4, 0.3, 0.3, 0.4, 0.0] * omega * np.cos(omega * 12.3))


def test_seeded_phases_keep_the_rms_and_differ_from_schroeder():
    schroeder, seeded = (multisine(np.ones(6), highest=0.5, components=4, seed=seed) for seed in (0, 7))
    assert not np.allclose(schroeder.phases, seeded.phases)
    t = np.arange(0.0, 48.0, 0.01)  # one period of 1/48 Hz
    values = np.array([seeded(time) for time in t])
    np.testing.assert_allclose(np.sqrt(np.mean(values ** 2, axis=0)), 1.0, rtol=1e-3)


@pytest.mark.parametrize("overrides, message", [
    (["excitation.wrench=[200, 200, 300, 6, 6, 15]"], r"times the thrusters' limits .* scale it by 0\.\d+"),
    (["plant.thrusters=false"], "excitation.wrench needs plant.thrusters = true"),
    (["excitation.wrench=[]", "excitation.highest=0.2"], "excitation.highest needs excitation.wrench"),
    (["excitation.arm=[0.1]"], "excitation.arm needs 5 amplitudes"),
    (["excitation.wrench=[1, 1, 1]"], "excitation: the excitation needs 6 amplitudes"),
    (["vehicle_control.pose_gains=2.0"], "vehicle_control.pose_gains is not used by an excitation"),
])
def test_a_bad_excitation_scenario_is_refused(tmp_path, overrides, message):
    with pytest.raises(ScenarioError, match=message):
        build(read_scenario(scenario_copy(tmp_path), overrides))
