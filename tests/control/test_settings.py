"""The actuated chain's settings (uvms.control.settings): one frozen object, the source of [vehicle_control]."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from uvms.control.settings import ActuatedSettings
from uvms.errors import ScenarioError, SolverInputError
from uvms.scenario import read_scenario
from uvms.scenario.spec import VehicleControlSpec


def test_vehicle_control_is_made_from_the_settings():
    """Every [vehicle_control] key is a field of ActuatedSettings with the same default, and the section gives the
    settings it sets (lists as tuples, frozen)."""
    keys = VehicleControlSpec.keys()
    assert set(keys) == set(ActuatedSettings.names())
    defaults = ActuatedSettings()
    assert all(keys[name].default == getattr(defaults, name) for name in keys)
    spec = read_scenario("bluerov2_alpha5_station_saturated", ["vehicle_control.kp=[100, 100, 100, 10, 10, 10]",
                                                               "vehicle_control.coordination=false"])
    settings = spec.vehicle_control.settings
    assert isinstance(settings, ActuatedSettings) and settings.kp == (100, 100, 100, 10, 10, 10)
    assert settings.coordination is False and settings.priorities == (("roll", "pitch", "yaw", "z"), ("x", "y"))
    with pytest.raises(dataclasses.FrozenInstanceError):
        settings.kp = None


def test_priorities_that_are_not_wrench_axes_are_refused_where_the_file_is_read():
    with pytest.raises(SolverInputError, match="groups of wrench axes among x, y, z, roll, pitch, yaw"):
        ActuatedSettings(priorities=(("surge",),))
    with pytest.raises(ScenarioError, match=r"station_saturated.toml: vehicle_control.priorities must be"):
        read_scenario("bluerov2_alpha5_station_saturated", ['vehicle_control.priorities=[["surge"]]'])
    assert ActuatedSettings(priorities=[["x", "y"], ["yaw"]]).priorities == (("x", "y"), ("yaw",))
    assert np.isclose(ActuatedSettings(bandwidth=[1, 2, 3, 4, 5, 6]).bandwidth[2], 3.0)


@pytest.mark.parametrize(("override", "message"), [
    ("vehicle_control.kp=-1", r"vehicle_control.kp must be a number or 6 numbers >= 0"),
    ("vehicle_control.ki=[1, 2, 3]", r"vehicle_control.ki must be a number or 6 numbers >= 0"),
    ("vehicle_control.bandwidth=0", r"vehicle_control.bandwidth must be a number or 6 numbers > 0"),
    ("vehicle_control.damping_ratio=[1, 1, 1, 1, 1, -1]", r"vehicle_control.damping_ratio must be .* > 0"),
    ("vehicle_control.pose_gains=-0.5", r"vehicle_control.pose_gains must be .* >= 0"),
    ("vehicle_control.max_speed=-1", r"vehicle_control.max_speed must be .* >= 0"),
])
def test_gains_out_of_their_range_are_refused_where_the_file_is_read(override, message):
    """A gain is checked when the settings are made: the scenario names the key before any model is loaded."""
    with pytest.raises(ScenarioError, match=rf"station_saturated.toml: {message}"):
        read_scenario("bluerov2_alpha5_station_saturated", [override])
    assert ActuatedSettings(kp=0.0, max_speed=None).kp == 0.0  # zero gains and no speed bound are valid
