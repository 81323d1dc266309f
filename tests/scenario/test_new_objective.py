"""What a new inequality type costs: one class and one registry entry, and every scenario can use it.

The objective below keeps one arm joint inside a window [lower, upper], written as a user would add one: an
:class:`uvms.tasks.objectives.Inequality` subclass that says what it is (``type_name``, ``unit``, ``min_metric``)
and one entry of :data:`uvms.tasks.objectives.INEQUALITY_TYPES`. Nothing in ``uvms/scenario``, ``uvms/viz`` or
``uvms/solvers`` names it, yet a scenario's ``[[inequalities]]`` table builds it, the set-based solver keeps the
joint inside the window, ``metrics.json`` reports it and ``inequalities.png`` draws it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from uvms.robot.configuration import Configuration
from uvms.scenario import run_scenario
from uvms.tasks.objectives import INEQUALITY_TYPES, Inequality, registered

from conftest import NO_FIGURES, SCENARIOS

#: hoang2011's circle: its 20 first seconds take the second arm joint q2 from 0 to -0.46 rad (clik, measured).
JOINT, WINDOW = "q2", (-0.3, 0.3)  # [rad]
SHORT = ["simulation.duration=20"]


class JointWindow(Inequality):
    """One arm joint inside [lower, upper] [rad or m]; the test's new type."""

    type_name = "joint_window"
    unit = "position [rad]"
    min_metric = "min_joint_window"

    def __init__(self, robot, joint: str, lower: float, upper: float, band: float = 0.1, gain: float = 1.0,
                 shape: str = "cosine", name: str | None = None) -> None:
        self.name = name or f"joint_window({joint})"
        pin_joint = robot.model.joints[robot.model.getJointId(joint)]
        self.q_index = pin_joint.idx_q
        self._jacobian = np.zeros((1, robot.nv))
        self._jacobian[0, pin_joint.idx_v] = 1.0
        self._set_valid_set(np.array([lower]), np.array([upper]), band, gain, shape)

    def value(self, state: Configuration) -> np.ndarray:
        return state.q[[self.q_index]]

    def jacobian(self, state: Configuration) -> np.ndarray:  # noqa: ARG002 - constant
        return self._jacobian


@pytest.fixture
def registered_window(monkeypatch):
    for name, kind in registered(JointWindow).items():
        monkeypatch.setitem(INEQUALITY_TYPES, name, kind)


def window_scenario(folder: Path) -> Path:
    """hoang2011_w1_set_based (its joint limits) plus a joint_window table, its model path made absolute."""
    source = SCENARIOS / "hoang2011_w1_set_based.toml"
    text = source.read_text().replace('path = "../models/', f'path = "{source.parent.parent.as_posix()}/models/')
    text += (f'\n[[inequalities]]\ntype = "joint_window"\njoint = "{JOINT}"\nlower = {WINDOW[0]}\n'
             f'upper = {WINDOW[1]}\n')
    path = folder / "window.toml"
    path.write_text(text)
    return path


def test_a_registered_inequality_type_is_enforced_reported_and_drawn(registered_window, tmp_path):
    scenario = window_scenario(tmp_path)
    run = run_scenario(scenario, tmp_path / "set_based", [*SHORT, "solver.method=set_based"], progress=False)
    name = f"joint_window({JOINT})"
    entry = run.metrics["inequalities"][name]
    assert entry["type"] == "joint_window" and entry["level"] == 1  # below the joint limits' table
    assert entry["max_violation"] == 0.0
    assert 0.0 < entry["active_fraction"] < 1.0  # the circle pushes q2 into the band, not all the time (0.54)
    assert entry["max_activation"] > 0.1  # measured 0.49
    assert run.metrics["final_position_error"] < 1e-8  # the task still tracked (measured 3.7e-12 m)
    joint = run.simulation.arm()[:, run.simulation.robot.arm_joint_names.index(JOINT)]
    assert WINDOW[0] - 1e-9 <= joint.min() and joint.max() <= WINDOW[1] + 1e-9  # kept inside the window
    assert joint.min() < WINDOW[0] + 0.1  # inside the band: the window held it (measured -0.249 rad)
    assert run.metrics["min_joint_window"] == pytest.approx(joint.min(), abs=1e-12)  # its own summary metric
    assert entry["value_range"][0] == pytest.approx(joint.min(), abs=1e-12)
    assert (tmp_path / "set_based" / "inequalities.png").stat().st_size > 10_000  # drawn among the others
    # monitored only (clik): the same table is reported, and the joint leaves the window
    monitored = run_scenario(scenario, tmp_path / "clik", [*SHORT, *NO_FIGURES, "solver.method=clik",
                                                           "solver.alpha=0"], progress=False)
    assert monitored.metrics["inequalities"][name]["max_violation"] > 0.1  # measured 0.163 rad below -0.3
    assert monitored.metrics["min_joint_window"] < WINDOW[0] - 0.1
