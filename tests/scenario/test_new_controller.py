"""What a new controller costs: one builder and one registry entry, and ``uvms run`` runs it.

The controller below is the plainest resolved-rate law, v = J^+ (xdot_d + K e) with numpy's pseudo-inverse, written
as a user would add one: a :class:`uvms.control.base.Controller` (``reset``, ``command``), a builder that makes it
from the parts the scenario's build made once (:class:`uvms.scenario.controllers.Parts`) and one entry of
:data:`uvms.scenario.controllers.CONTROLLERS`. Nothing in ``uvms/scenario`` or ``uvms/control`` names it, yet
``uvms run --set controller.type=...`` runs it and tracks the hoang2011 circle as CLIK does (the same law: W = I, no
null-space term).
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from uvms.cli import main
from uvms.control.base import Command, State
from uvms.errors import ScenarioError
from uvms.robot.configuration import Configuration
from uvms.scenario import read_scenario
from uvms.scenario.controllers import CONTROLLERS, Parts, Setup
from uvms.scenario.spec import ScenarioSpec

from conftest import SCENARIOS, assert_tracks_like_clik, run_beside_clik


class PseudoInverseTracking:
    """v = J^+ (xdot_d + K e) (nv,) of the task along the trajectory, K [1/s]; the test's new controller."""

    def __init__(self, robot, task, trajectory, gain: float) -> None:
        self.robot, self.task, self.trajectory, self.gain = robot, task, trajectory, gain

    def reset(self, state: State, t: float = 0.0) -> None:
        """Nothing is kept between calls."""

    def command(self, state: State, t: float) -> Command:
        sample = self.trajectory(t)
        self.task.set_target(sample.pose)
        self.task.set_target_velocity(sample.twist)
        jacobian, error, feedforward = self.task.terms(Configuration(self.robot, state.q))  # (k, nv), (k,), (k,)
        sigma = np.linalg.svd(jacobian, compute_uv=False)
        info = SimpleNamespace(sigma_min=float(sigma.min()), damping=0.0, limits_active=())
        return Command(velocity=np.linalg.pinv(jacobian) @ (feedforward + self.gain * error), info=info)


def build_pinv_tracking(spec: ScenarioSpec, parts: Parts) -> Setup:
    """The test's builder: the controller on the parts build made (model, task, q0, trajectory)."""
    return parts.setup(PseudoInverseTracking(parts.robot, parts.task, parts.trajectory, float(spec.solver.gain)))


@pytest.fixture
def registered(monkeypatch):
    monkeypatch.setitem(CONTROLLERS, "pinv_tracking", build_pinv_tracking)


def test_a_registered_controller_runs_a_scenario_like_clik(registered, tmp_path):
    clik, new = run_beside_clik(tmp_path, "controller.type=pinv_tracking")  # CLIK without its null-space term
    assert_tracks_like_clik(new, clik, error=1e-12, rel=1e-9, also=("min_sigma_min",))


def test_an_unregistered_controller_is_refused_with_the_valid_types(tmp_path, capsys):
    for name in ("pinv_tracking", "gjm"):  # not registered; chosen by the plant, not named
        code = main(["run", "hoang2011_w1", "--out", str(tmp_path / "x"), "--set", f"controller.type={name}",
                     "--quiet"])
        err = capsys.readouterr().err
        assert code == 2 and f"controller.type = {name!r} is not valid; valid: 'solver', 'mpc'" in err


def test_the_mpc_keys_are_refused_on_a_registered_controller(registered):
    with pytest.raises(ScenarioError, match=r"controller.horizon is a setting of the MPC; it needs controller.type = "
                                        r"'mpc' \(got 'pinv_tracking'\)"):
        read_scenario("hoang2011_w1", ["controller.type=pinv_tracking", "controller.horizon=5"])


@pytest.mark.parametrize(("scenario", "kind"), [
    ("hoang2011_w1", "tracking"), ("hoang2011_gjm", "gjm"), ("bluerov2_alpha5_intervention", "actuated"),
    ("bluerov2_excitation", "excitation"), ("xiang2019_grip", "sequence"), ("bluerov2_alpha5_intervention_mpc", "mpc"),
])
def test_the_controller_is_chosen_from_the_file_alone(scenario, kind):
    spec = read_scenario(SCENARIOS / f"{scenario}.toml")
    assert spec.controller_kind == kind and kind in CONTROLLERS


def test_a_sequence_from_an_optimized_start_is_refused_where_the_file_is_read():
    message = "a sequence scenario needs initial.method = 'given' and one number for solver.gain"
    for override in ("initial.method=optimize", "solver.gain=[1, 2]"):  # before the model loads: no build
        with pytest.raises(ScenarioError, match=message):
            read_scenario(SCENARIOS / "xiang2019_grip.toml", [override])
