"""Thrusters and fins allocated together (uvms.dynamics.thrusters.fin_allocation): the fins' columns at the step's
speed, what they make reachable, and no fin swung to its limit for a direction it cannot give."""

from pathlib import Path

import numpy as np
import pytest

import uvms
from uvms.dynamics.thrusters.allocation import ThrustAllocator
from uvms.dynamics.thrusters.fin_allocation import MIN_SPEED, FinAllocator
from uvms.dynamics.thrusters.fins import fins_of
from uvms.dynamics.thrusters.thrusters import allocation_matrix, thrusters_of
from uvms.errors import BaseGuessWarning, PointMassWarning

TORPEDO = Path(__file__).parents[2] / "fixtures" / "auv" / "torpedo.urdf"


@pytest.fixture(scope="module")
def torpedo():
    with pytest.warns(PointMassWarning), pytest.warns(BaseGuessWarning):
        robot = uvms.load(TORPEDO)
    thrusters, fins = thrusters_of(robot), fins_of(robot)
    return robot, thrusters, fins


def allocator(torpedo, priorities=None):
    robot, thrusters, fins = torpedo
    return FinAllocator(allocation_matrix(robot, thrusters), thrusters.lower, thrusters.upper, fins,
                        priorities=priorities)


def surge(speed):
    return np.array([speed, 0.0, 0.0, 0.0, 0.0, 0.0])


def test_at_rest_the_propeller_alone_and_at_speed_the_fins_add_three_directions(torpedo):
    """One propeller: 1 of 6 directions at rest (the fins give no lift); at 1 m/s the elevators add heave with
    pitch, the rudders sway with yaw, all four roll: 4 of 6. The note says both."""
    fins = allocator(torpedo)
    assert fins.thrusters.rank == 1 and fins.at(surge(0.0))[0].rank == 1 and fins.at(surge(1.0))[0].rank == 4
    note = fins.reach_note(torpedo[1].names)
    assert note.startswith("at rest the thrusters produce 1 of the 6 body-wrench directions; missing: a y force, a z "
                           "force, a roll moment, a pitch moment, a yaw moment")
    assert ("at 1 m/s forward through the water the 4 fins' lift adds 3 directions (the lift grows with the speed "
            "squared, none at rest): the thrusters and fins produce 4 of the 6 body-wrench directions; missing: a "
            "pitch moment, a yaw moment") in note
    assert "pushing against each other" not in note  # the cross's null pattern is exact, not a fight


@pytest.mark.parametrize("speed", (1.0, 2.0))
def test_a_reachable_wrench_is_met_by_the_true_lift_of_the_allocated_angles(torpedo, speed):
    """A surge force with a pitch moment and the heave the elevators give with it: attained by the linearization;
    the fins' true lift at the allocated angles gives the pitch within the drag's share; the angles fall as 1/u^2."""
    fins = allocator(torpedo)
    wrench = np.array([8.0, 0.0, 2.0, 0.0, 1.5, 0.0])  # heave : pitch = 20 : 15, the elevators' ratio
    result = fins.allocate(wrench, surge(speed))
    assert result.attainable and not result.saturated.any()
    thrust, angles = result.thrusts[0], result.thrusts[1:]
    assert thrust == pytest.approx(8.0)
    np.testing.assert_allclose(angles, np.array([0.05, 0.0, -0.05, 0.0]) / speed**2, atol=1e-12)
    true = torpedo[2].wrench(surge(speed), np.zeros(3), angles)
    np.testing.assert_allclose(true[2:], wrench[2:], atol=1e-12)
    assert true[0] == pytest.approx(-2 * 9.0 * (0.05 / speed**2) ** 2 * speed**2)  # the drag: a disturbance


def test_no_fin_swings_to_a_limit_for_a_direction_the_fins_cannot_give(torpedo):
    """A small sway and yaw rate make the fins' inflow differ in the fifth digit; linearized at that twist, the cross's
    near-null pattern (the four fins pushing against each other) reached pitch without heave at the limits (+-0.4
    rad). With the columns at the surge, the fins give the reachable part only."""
    twist = np.array([1.0, 1e-4, -1e-4, 0.0, 1e-4, 1e-4])
    result = allocator(torpedo).allocate(np.array([8.0, 0.0, -0.2, 0.0, 0.4, 0.1]), twist)
    assert np.max(np.abs(result.thrusts[1:])) < 0.02 and not result.saturated.any()


def test_below_the_minimum_speed_the_fins_stay_at_rest(torpedo):
    result = allocator(torpedo).allocate(np.array([5.0, 0.0, 0.0, 0.0, 0.3, 0.0]), surge(0.9 * MIN_SPEED))
    np.testing.assert_array_equal(result.thrusts[1:], 0.0)
    assert result.thrusts[0] == pytest.approx(5.0) and not result.attainable


def test_priorities_order_what_is_left_of_an_unreachable_wrench():
    """A thruster and a fin that gives heave 20 with pitch 15 per unit: pitch 2.6 N m and heave -1.4 N cannot both be
    had. Before, the least squares over all axes (no bound reached) ignored the priorities: pitch 0.26 N m; with pitch
    first the fin gives the whole pitch moment."""
    matrix = np.array([[1.0, 0, 0, 0, 0, 0], [0, 0, 20.0, 0, 15.0, 0]]).T
    wrench = np.array([3.0, 0.0, -1.4, 0.0, 2.6, 0.0])
    plain = ThrustAllocator(matrix, [-10.0, -1.0], [10.0, 1.0]).allocate(wrench)
    assert plain.solver == "pinv" and plain.achieved_wrench[4] == pytest.approx(15 * (-28 + 39) / 625)
    first = ThrustAllocator(matrix, [-10.0, -1.0], [10.0, 1.0], priorities=[["pitch"], ["x", "y", "z", "roll", "yaw"]])
    result = first.allocate(wrench)
    assert result.achieved_wrench[4] == pytest.approx(2.6) and result.achieved_wrench[0] == pytest.approx(3.0)
