"""The vehicle loops' compiled arithmetic (uvms.numerics._kernels.vehicle) gives the numbers of the numpy expressions
it replaced in uvms.control.vehicle and uvms.control.coordination, bit for bit (signed zeros included)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from uvms.numerics._kernels.vehicle import (
    disturbance_update,
    observer_inputs,
    reference_rate_into,
    vehicle_wrench,
    velocity_wrench,
)


def same(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and a.tobytes() == b.tobytes()


def vectors(rng: np.random.Generator, size: int) -> np.ndarray:
    """Numbers over many scales, some exactly zero of either sign."""
    values = rng.standard_normal(size) * 10.0 ** rng.uniform(-6, 3, size)
    values[rng.random(size) < 0.15] = 0.0
    values[rng.random(size) < 0.1] = -0.0
    return values


def test_the_observer_inputs_are_numpys(rng):
    for _ in range(500):
        v, v0, dt = vectors(rng, 11), vectors(rng, 11), float(10.0 ** rng.uniform(-4, -1))
        acceleration, mean = observer_inputs(v, v0, dt)
        assert same(acceleration, (v - v0) / dt) and same(mean, 0.5 * (v0 + v))


def numpy_disturbance(needed, applied0, applied, disturbance, gain, short):
    """VehicleVelocityController.observe's update before the kernel."""
    mismatch = needed - 0.5 * (applied0 + applied)
    update = gain * (mismatch - disturbance)
    if not short.any():
        return disturbance + update
    winding = short * -update > 0.0
    return disturbance + np.where(winding, gain * short, np.where(short != 0.0, 0.0, update))


def test_the_disturbance_update_is_numpys_with_and_without_a_shortfall(rng):
    winding = 0
    for trial in range(2000):
        needed, applied0, applied, disturbance = (vectors(rng, 6) for _ in range(4))
        gain = -np.expm1(-0.01 / float(rng.uniform(0.05, 1.0)))
        short = np.zeros(6) if trial % 2 else np.where(rng.random(6) < 0.5, vectors(rng, 6), 0.0)
        old = numpy_disturbance(needed, applied0, applied, disturbance, gain, short)
        assert same(disturbance_update(needed, applied0, applied, disturbance, gain, short, bool(short.any())), old)
        winding += int(np.sum(short * -gain * (needed - 0.5 * (applied0 + applied) - disturbance) > 0))
    assert winding > 100  # the back-calculation's branch was taken


def test_the_velocity_law_is_numpys(rng):
    for _ in range(1000):
        reference, nu, feedforward, kp, ki, integral, disturbance = (vectors(rng, 6) for _ in range(7))
        error, wrench = velocity_wrench(reference, nu, feedforward, kp, ki, integral, disturbance)
        old_error = reference - nu
        assert same(error, old_error)
        assert same(wrench, feedforward + kp * old_error + ki * integral - disturbance)


def test_the_reference_rate_filter_is_numpys_in_place(rng):
    rate, old = vectors(rng, 6), None
    old = rate.copy()
    for _ in range(500):
        reference, last, dt = vectors(rng, 6), vectors(rng, 6), float(10.0 ** rng.uniform(-3, -1))
        step = (reference - last) / dt
        old += (step - old) * dt / (0.1 + dt)
        reference_rate_into(reference, last, rate, dt, 0.1)
        assert same(rate, old)


def test_the_vehicle_rows_are_numpys_and_pinocchios(rng):
    """vehicle_inverse_dynamics's tail: numpy's products of Mbar's slices, then Pinocchio's SE3.actInv of the joint's
    force (any placement, the identity of the shipped vehicles included; arms of 0 to 6 joints)."""
    for trial in range(4000):
        n_arm = trial % 7
        mass, bias = rng.standard_normal((6 + n_arm, 6 + n_arm)) * 50.0, vectors(rng, 6 + n_arm)
        base, arm = vectors(rng, 6), vectors(rng, n_arm)
        placement = pin.SE3.Random() if trial % 2 else pin.SE3.Identity()
        joint = mass[:6, :6] @ base + mass[:6, 6:] @ arm + bias[:6]
        old = placement.actInv(pin.Force(joint)).vector
        assert same(vehicle_wrench(mass, bias, base, arm, placement.rotation, placement.translation), old)
    with pytest.raises(ValueError):
        vehicle_wrench(mass, bias, base[:3], arm, placement.rotation, placement.translation)
