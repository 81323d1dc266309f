"""A log's thruster topics as the body wrench (uvms.scenario.bags.thrust_log, read_bag(..., thrust=...)): the thrusts
uvms run --bag writes, or thrust commands through the thrusters' limits and lag, mapped by the allocation matrix."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from uvms.dynamics.identification.identify import identify
from uvms.dynamics.thrusters.thrusters import thrusters_of
from uvms.errors import IdentificationError
from uvms.scenario.bags.reader import read_bag
from uvms.scenario.bags.thrust_log import SETTLING, thrust_input
from uvms.scenario.bags.writer import write_bag

from conftest import excitation, shipped


@pytest.fixture(scope="module")
def bags(tmp_path_factory):
    """The held-arm excitation (60 s, 50 Hz) as a bag, and as a bag whose thruster topics hold the commands."""
    robot = shipped("bluerov2_alpha5")
    run, _ = excitation("held")
    folder = tmp_path_factory.mktemp("thrust")
    names = thrusters_of(robot).names
    commanded = dataclasses.replace(run, actuation=dataclasses.replace(run.actuation,
                                                                       thrusts=run.actuation.thrust_command))
    return (write_bag(folder / "thrusts", robot, run, thrusters=names).path,
            write_bag(folder / "commands", robot, commanded, thrusters=names).path)


def test_the_thrusts_give_the_body_wrench_topic(bags):
    robot = shipped("bluerov2_alpha5")
    from_wrench = read_bag(bags[0])
    from_thrusts = read_bag(bags[0], thrust=thrust_input(robot), wrench_topic="/not_read")
    np.testing.assert_array_equal(from_thrusts.t, from_wrench.t)
    np.testing.assert_allclose(from_thrusts.wrench, from_wrench.wrench, atol=1e-9 * np.abs(from_wrench.wrench).max())


def test_thrust_commands_through_the_lag_give_the_wrench_and_the_parameters(bags):
    robot = shipped("bluerov2_alpha5")
    thrust = thrust_input(robot, commands=True)
    assert thrust.settling == pytest.approx(SETTLING * 0.1)  # the T200's 0.1 s (models/bluerov2_alpha5/thrusters.yaml)
    truth = read_bag(bags[0])
    log = read_bag(bags[1], thrust=thrust)
    offset = round(thrust.settling / 0.02)  # the first 1 s dropped: the thrust before the first command is unknown
    assert len(log.t) == len(truth.t) - offset
    # the exact solution of the lag (command held over a step) against the plant's RK4 (its error per step about
    # (dt / T)^5 / 120 = 3e-6 of the thrust): measured 3.3e-6 of the largest wrench
    np.testing.assert_allclose(log.wrench, truth.wrench[offset:], atol=1e-5 * np.abs(truth.wrench).max())
    result = identify(robot, log)
    errors = [abs(p.value - p.prior) / abs(p.prior) for p in result.parameters if p.identified and p.prior != 0.0]
    assert len(errors) >= 16 and max(errors) < 0.02


def test_the_commands_are_clipped_to_the_limits_before_the_lag():
    robot = shipped("bluerov2_alpha5")
    thrust = thrust_input(robot, commands=True)
    t = np.array([0.0, 0.1, 0.2, 0.3])
    upper, tau = thrust.upper[0], thrust.time_constants[0]
    values = thrust.thrust(0, t, np.array([0.0, 10 * upper, 10 * upper, 0.0]))
    # f(0.1) = 0 (the command 0 held); then towards the limit: f(0.2) = upper (1 - e^(-0.1/tau)), f(0.3) = ...
    expected_2 = upper * (1 - np.exp(-0.1 / tau))
    np.testing.assert_allclose(values, [0.0, 0.0, expected_2, upper + (expected_2 - upper) * np.exp(-0.1 / tau)])


def test_a_bag_without_a_thruster_topic_is_refused(bags):
    robot = shipped("bluerov2_alpha5")
    with pytest.raises(IdentificationError, match=r"the bag has no thrust of thruster_1 topic '/t/thruster_1/x'"):
        read_bag(bags[0], thrust=thrust_input(robot, "/t/{name}/x"))


def test_a_thruster_topic_of_the_wrong_type_is_refused(bags):
    """The thrust topics are std_msgs/Float64: a pattern leading to the odometry is named with both types."""
    robot = shipped("bluerov2_alpha5")
    names = thrusters_of(robot).names
    renamed = thrust_input(robot, "/{name}")
    renamed = dataclasses.replace(renamed, topics=("/odom", *renamed.topics[1:]))
    with pytest.raises(IdentificationError, match=f"topic '/odom' holds nav_msgs/msg/Odometry; the thrust of "
                                                  f"{names[0]} must be std_msgs/msg/Float64"):
        read_bag(bags[0], thrust=renamed)


@pytest.mark.parametrize("pattern", ["/thrusters/thrust", "/{name}/{name}", "/{id}"])
def test_a_pattern_without_one_name_is_refused(pattern):
    with pytest.raises(IdentificationError, match=r"must hold \{name\} once"):
        thrust_input(shipped("bluerov2_alpha5"), pattern)


def test_a_model_without_thrusters_cannot_read_thrusts():
    with pytest.raises(IdentificationError, match="a log of thrusts needs the model's thrusters"):
        thrust_input(shipped("amundsen2018"))
