"""The vehicle loops' compiled arithmetic (uvms.numerics._kernels.vehicle) gives the numbers of the numpy expressions
it replaced in uvms.control.vehicle and uvms.control.coordination, bit for bit (signed zeros included)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import uvms
from uvms.dynamics.plant.actuated import vehicle_inverse_dynamics
from uvms.dynamics.plant.plant import Plant
from uvms.numerics._kernels.vehicle import (
    base_reference,
    disturbance_update,
    observer_inputs,
    station_errors,
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


def placements(rng: np.random.Generator, count: int):
    """Random placements, every other one the identity (the shipped vehicles' base frame)."""
    for trial in range(count):
        placement = pin.SE3.Random() if trial % 2 else pin.SE3.Identity()
        yield trial, placement, placement.rotation.copy(), placement.translation.copy()


def test_the_velocity_law_is_pinocchios_and_numpys(rng):
    """nu as base_twist computes it (Pinocchio's SE3.actInv of v's vehicle part), then numpy's PI law."""
    for _, placement, rotation, translation in placements(rng, 3000):
        reference, feedforward, kp, ki, integral, disturbance = (vectors(rng, 6) for _ in range(6))
        v = vectors(rng, 11)
        nu, error, wrench = velocity_wrench(reference, v, rotation, translation, feedforward, kp, ki, integral,
                                            disturbance)
        old_nu = placement.actInv(pin.Motion(v[:6])).vector
        old_error = reference - old_nu
        assert same(nu, old_nu) and same(error, old_error)
        assert same(wrench, feedforward + kp * old_error + ki * integral - disturbance)


def test_the_base_reference_and_its_rate_are_pinocchios_and_numpys_in_place(rng):
    rate = vectors(rng, 6)
    old = rate.copy()
    for trial, placement, rotation, translation in placements(rng, 2000):
        reference, last, dt = vectors(rng, 11), vectors(rng, 6), float(10.0 ** rng.uniform(-3, -1))
        filtered = trial % 3 != 0
        nu_ref = base_reference(reference, rotation, translation, last, rate, dt, 0.1, filtered)
        old_nu_ref = placement.actInv(pin.Motion(reference[:6])).vector
        assert same(nu_ref, old_nu_ref)
        if filtered:
            step = (old_nu_ref - last) / dt
            old += (step - old) * dt / (0.1 + dt)
        assert same(rate, old)


def test_the_vehicle_rows_are_numpys_and_pinocchios(rng):
    """vehicle_inverse_dynamics's tail: numpy's products of Mbar's slices, then Pinocchio's SE3.actInv of the joint's
    force (any placement, the identity of the shipped vehicles included; arms of 0 to 6 joints)."""
    for trial, placement, rotation, translation in placements(rng, 4000):
        n_arm = trial % 7
        mass, bias = rng.standard_normal((6 + n_arm, 6 + n_arm)) * 50.0, vectors(rng, 6 + n_arm)
        base, arm = vectors(rng, 6), vectors(rng, n_arm)
        joint = mass[:6, :6] @ base + mass[:6, 6:] @ arm + bias[:6]
        old = placement.actInv(pin.Force(joint)).vector
        assert same(vehicle_wrench(mass, bias, base, arm, rotation, translation), old)
    with pytest.raises(ValueError):
        vehicle_wrench(mass, bias, base[:3], arm, rotation, translation)


def test_the_station_errors_are_numpys(rng):
    """ActuatedKinematics.errors' R^T R_d (Pinocchio's rotations, F-ordered, as the errors read them) and |p_d - p|
    (numpy's sqrt of x.dot(x))."""
    for _ in range(3000):
        pose, target = pin.SE3.Random(), pin.SE3.Random()
        pose.translation, target.translation = vectors(rng, 3), vectors(rng, 3)
        relative, distance = station_errors(pose.rotation, pose.translation, target.rotation, target.translation)
        offset = target.translation - pose.translation
        assert same(relative, pose.rotation.T @ target.rotation)
        assert distance == np.sqrt(offset.dot(offset)) and type(distance) is float


def test_vehicle_inverse_dynamics_gives_its_numpy_and_pinocchio_numbers_for_arrays_and_lists(rng):
    """vehicle_inverse_dynamics through the compiled rows equals its expressions before them, at random states of the
    BlueROV2 + Alpha 5 (accelerations given as arrays or as lists, as before)."""
    robot = uvms.load("bluerov2_alpha5")
    plant = Plant(robot, gravity=True, current=[0.2, -0.1, 0.05])
    for _ in range(20):
        q = pin.randomConfiguration(robot.model, -np.ones(robot.nq), np.ones(robot.nq))
        q[3:7] /= np.linalg.norm(q[3:7])
        v, base, arm = rng.normal(size=robot.nv), rng.normal(size=6), rng.normal(size=robot.n_arm)
        mass, bias = plant._mass_and_bias(q, v)
        old = plant.base_placement.actInv(pin.Force(mass[:6, :6] @ base + mass[:6, 6:] @ arm + bias[:6])).vector
        assert same(vehicle_inverse_dynamics(plant, q, v, base, arm), old)
        assert same(vehicle_inverse_dynamics(plant, q, v, base.tolist(), arm.tolist()), old)
