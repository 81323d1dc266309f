"""A kinematic run's recorder reads the objectives' rows its controller's solve evaluated at the row's q."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pinocchio as pin

from uvms.dynamics.plant.command import State
from uvms.scenario.build import build
from uvms.scenario.inequalities import ObjectiveRecorder
from uvms.scenario.schema import read_scenario

from conftest import SCENARIOS


def test_the_recorder_reads_the_tracking_solves_rows_and_pairs_at_the_rows_q():
    """The pipe (set-based, the jaws' clearance from the pipe above the point): after the controller's command at q
    the recorder's row with the solve's rows equals, bit for bit, the row it evaluates itself (values,
    activations, activity and each row's pair of shapes), without querying a distance again; at another q
    there are no rows and it evaluates them."""
    setup = build(read_scenario(SCENARIOS / "bluerov2_alpha5_pipe.toml", ["outputs.figures=false"]))
    controller, robot = setup.controller, setup.robot
    reading = ObjectiveRecorder(robot, setup.inequalities, controller.objective_rows)
    evaluating = ObjectiveRecorder(robot, setup.inequalities)
    q = setup.q0
    assert controller.objective_rows(q) is None  # no solve yet
    controller.reset(State(q), 0.0)
    command = controller.command(State(q), 0.0)
    assert controller.objective_rows(q) is not None
    assert controller.objective_rows(pin.integrate(robot.model, q, 1e-9 * np.ones(robot.nv))) is None
    queries = []
    for objective in setup.inequalities.objectives:  # a distance query or an evaluation again would be counted
        if objective.collision:
            objective.nearest = lambda state, objective=objective: queries.append(objective.name) or \
                type(objective).nearest(objective, state)
        objective.value = lambda state, objective=objective: queries.append(objective.name) or \
            type(objective).value(objective, state)
    sample = SimpleNamespace(rate=(command.velocity, None), info=command.info)
    read = reading(0.0, q, None, sample)
    assert queries == []
    alone = evaluating(0.0, q, None, sample)
    assert len(queries) == len(setup.inequalities.objectives)
    for name in ("objective_value", "objective_activation", "objective_active", "objective_pair"):
        first, second = np.asarray(read[name]), np.asarray(alone[name])  # as the loop stacks a row's values
        assert first.dtype == second.dtype and first.tobytes() == second.tobytes(), name
    assert read["objective_pair"].size > 0 and read["speed_ratio"] == alone["speed_ratio"]
