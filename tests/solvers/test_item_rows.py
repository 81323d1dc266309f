"""The rows of tasks and objectives one hierarchy evaluated, read by a second at the same configuration
(uvms.solvers.item_rows)."""

from __future__ import annotations

import numpy as np

import uvms
from uvms.robot.configuration import Configuration
from uvms.solvers.item_rows import ItemRows
from uvms.tasks.objectives import VehicleAttitude


def test_shared_rows_follow_the_value_of_q_in_one_state():
    """An ItemRows read through one state moved in place: kept when q comes back equal (a copy), evaluated again when
    one entry moves by 1e-12 or is NaN."""
    robot = uvms.load("bluerov2_alpha5")
    q = robot.configuration(base=[0, 0, -5, 0.02, -0.01, 0.3], arm=[3.0, 1.8, 1.8, 1.0, 0.0])
    state, shared = Configuration(robot, q), ItemRows()
    objective = VehicleAttitude(robot, np.radians(5.0))
    first = shared.at(state).objective(objective)
    state.update(q.copy())
    assert shared.at(state).objective(objective) is first
    moved = q.copy()
    moved[0] += 1e-12
    state.update(moved)
    assert shared.at(state).objective(objective) is not first
    kept = shared.objective(objective)
    moved[0] = np.nan  # NaN is never equal to itself: the rows are dropped
    state.update(moved, check=False)
    assert shared.at(state)._objectives == {} and kept is not None
