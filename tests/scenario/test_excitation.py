"""Excitation for identification (uvms.scenario.excitation): the multi-sine, the run, its log, the noise."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from uvms.errors import IdentificationError
from uvms.scenario.excitation import arm_motion, log_of_run, multisine, with_odometry_noise

from conftest import excitation, shipped


def test_the_multisine_has_its_rms_and_no_shared_frequency():
    signal = multisine(np.array([20.0, 10.0, 0.0, 1.0, 2.0, 3.0]), highest=0.5, components=8)
    assert len(set(np.round(signal.frequencies.ravel(), 12))) == 48
    assert signal.frequencies.min() == pytest.approx(0.5 / 48) and signal.frequencies.max() == pytest.approx(0.5)
    t = np.arange(0.0, 96.0, 0.01)  # a whole period of the grid's 1/96 Hz
    values = np.array([signal(time) for time in t])
    np.testing.assert_allclose(np.sqrt(np.mean(values ** 2, axis=0)), signal.amplitudes, rtol=1e-3, atol=1e-12)


@pytest.mark.parametrize("amplitudes, highest, message", [([1.0] * 5, 1.0, "6 amplitudes"),
                                                            ([-1.0] * 6, 1.0, "6 amplitudes"),
                                                            ([1.0] * 6, 0.0, "highest frequency")])
def test_a_bad_multisine_is_refused(amplitudes, highest, message):
    with pytest.raises(IdentificationError, match=message):
        multisine(np.array(amplitudes), highest=highest)


def test_the_arm_motion_is_the_derivative_of_its_sines():
    motion = arm_motion(np.array([0.3, 0.2]), period=10.0)
    t = np.linspace(0.0, 10.0, 2001)
    positions = np.cumsum([motion(time) for time in t], axis=0) * (t[1] - t[0])
    np.testing.assert_allclose(positions[-1], [0.3 * np.sin(2 * np.pi), 0.2 * np.sin(2 * np.pi * 1.37)], atol=5e-3)


def test_the_excitation_run_moves_every_axis_within_the_thrusters_limits():
    run, log = excitation("heave_pitch")
    thrusts = run.actuation.thrusts
    assert thrusts.max() < 51.5 and thrusts.min() > -40.2  # T200 limits: never saturated
    twist = log.twist
    assert twist[:, 2].std() > 0.1 and twist[:, 4].std() > 0.1  # heave and pitch move
    assert twist[:, 1].std() < 0.01  # sway hardly (nothing drives it)
    # the log's wrench is the thrusters' B f at each sample
    np.testing.assert_allclose(log.wrench, run.actuation.body_wrench)


def test_a_run_without_thrusters_has_no_log():
    from uvms.dynamics.plant.plant import Plant
    from uvms.sim.loop import simulate

    robot = shipped("bluerov2_alpha5")
    run = simulate(Plant(robot), None, pin.neutral(robot.model), 0.1, 0.05, progress=False)
    with pytest.raises(IdentificationError, match="actuated vehicle"):
        log_of_run(robot, run)


def test_the_odometry_noise_has_its_standard_deviations():
    _, log = excitation("heave_pitch")
    noisy = with_odometry_noise(log, position=0.05, attitude=0.01, linear=0.02, angular=0.03, seed=0)
    np.testing.assert_allclose(np.std(noisy.position - log.position, axis=0), 0.05, rtol=0.1)
    np.testing.assert_allclose(np.std(noisy.twist - log.twist, axis=0), [0.02] * 3 + [0.03] * 3, rtol=0.1)
    angles = [pin.log3(pin.Quaternion(np.asarray(a)).toRotationMatrix().T @ pin.Quaternion(np.asarray(b))
                       .toRotationMatrix()) for a, b in zip(log.quaternion, noisy.quaternion)]
    np.testing.assert_allclose(np.std(angles, axis=0), 0.01, rtol=0.1)
    np.testing.assert_array_equal(noisy.wrench, log.wrench)
