"""A constant current identified with the vehicle's parameters (uvms.dynamics.identification.current): the
BlueROV2 + Alpha 5 under the multi-sine in a current of (0.2, -0.1, 0.03) m/s (world ENU), noise free and with the
odometry noise of test_identification (position 5 cm, attitude 0.005 rad, 0.01 m/s, 0.01 rad/s)."""

from __future__ import annotations

import functools

import numpy as np
import pinocchio as pin

from uvms.dynamics.hydro.hydrodynamics import hydrodynamics_of
from uvms.dynamics.identification.current import MAX_CURRENT_ERROR, estimate_current
from uvms.dynamics.identification.data import SmoothedStates
from uvms.dynamics.identification.identify import identify
from uvms.dynamics.identification.model import Regression, parameter_layout
from uvms.scenario.excitation import excitation_run, log_of_run, multisine, with_odometry_noise

from conftest import ARM_START, EXCITATIONS, shipped

CURRENT = np.array([0.2, -0.1, 0.03])
NOISE = {"position": 0.05, "attitude": 0.005, "linear": 0.01, "angular": 0.01}


@functools.lru_cache(maxsize=None)
def log_in_current():
    """The held-arm excitation (60 s at 50 Hz) in the current CURRENT."""
    robot = shipped("bluerov2_alpha5")
    amplitudes, _, duration, dt = EXCITATIONS["held"]
    q0 = pin.neutral(robot.model)
    q0[2] = -5.0
    q0[7:12] = ARM_START["held"]
    run, _ = excitation_run(robot, multisine(np.array(amplitudes)), q0, duration, dt, current=CURRENT)
    return log_of_run(robot, run, "excitation in a current")


def parameter_errors(result) -> dict[str, float]:
    return {p.name: abs(p.value - p.prior) / abs(p.prior) for p in result.parameters
            if p.identified and p.prior != 0.0 and not p.name.startswith("current")}


def current_of(result) -> tuple[np.ndarray, list]:
    estimates = [result.parameter(f"current[{axis}]") for axis in "xyz"]
    return np.array([p.value for p in estimates]), estimates


def test_a_noise_free_log_gives_the_current_and_every_parameter():
    robot = shipped("bluerov2_alpha5")
    result = identify(robot, log_in_current(), identify_current=True)  # the search starts at the prior's 0
    current, estimates = current_of(result)
    np.testing.assert_allclose(current, CURRENT, atol=1e-3)  # measured: within 0.25 mm/s
    assert all(p.identified and p.prior == 0.0 for p in estimates)
    assert max(parameter_errors(result).values()) < 0.02  # measured 1.03 % (linear_damping[u])
    np.testing.assert_array_equal(result.hydro.current, current)  # written into hydrodynamics.yaml
    report = result.as_dict()  # identification.json
    assert [p["name"] for p in report["parameters"]][-3:] == ["current[x]", "current[y]", "current[z]"]
    assert report["options"]["identify_current"]
    # assuming still water instead, the damping soaks up the current: a parameter more than twice its truth
    assert max(parameter_errors(identify(robot, log_in_current())).values()) > 1.0  # measured 239 %


def test_with_odometry_noise_the_current_intervals_cover_the_truth():
    noisy = with_odometry_noise(log_in_current(), seed=1, **NOISE)
    result = identify(shipped("bluerov2_alpha5"), noisy, identify_current=True)
    current, estimates = current_of(result)
    np.testing.assert_allclose(current, CURRENT, atol=5e-3)  # measured: within 0.9 mm/s
    for estimate, truth in zip(estimates, CURRENT):
        low, high = estimate.interval
        assert low <= truth <= high and estimate.std_error < 0.01
    assert max(parameter_errors(result).values()) < 0.10  # measured 3.7 %


def test_a_log_that_does_not_depend_on_the_current_holds_it():
    """A regression that no current changes: the current has no information and is held at its start."""
    count = 200
    rng = np.random.default_rng(0)
    regressor, target = rng.normal(size=(count, 6, 22)), rng.normal(size=(count, 6))
    data = Regression(target, regressor, None, None, None, np.eye(6), np.zeros(6))
    zeros = np.zeros((count, 6))
    states = SmoothedStates(np.arange(count) * 0.02, zeros[:, :3], zeros[:, :4], target, zeros, zeros, zeros,
                            zeros[:, :0], zeros[:, :0], zeros[:, :0], np.zeros(6), 15, 0.02)
    layout = parameter_layout(hydrodynamics_of(shipped("bluerov2_alpha5")).links["base_link"], np.eye(6))
    start = np.array([0.1, 0.0, 0.0])
    found = estimate_current(lambda current, sub: data, layout, states, start)
    assert found.std_error is None and f"> {MAX_CURRENT_ERROR:g} m/s" in found.reason
    np.testing.assert_array_equal(found.value, start)
