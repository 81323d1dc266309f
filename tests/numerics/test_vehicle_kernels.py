"""The vehicle loops' compiled arithmetic (uvms.numerics._kernels.vehicle) gives the numbers of the numpy expressions
it replaced in uvms.control.vehicle and uvms.control.coordination, bit for bit (signed zeros included)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import uvms
from uvms.control.coordination import achieved_ratio
from uvms.control.vehicle import VehiclePoseController, pose_velocity_reference
from uvms.dynamics.plant.actuated import lag_command, vehicle_inverse_dynamics
from uvms.dynamics.plant.plant import Plant
from uvms.numerics._kernels.vehicle import (
    arm_command_into,
    base_reference_into,
    disturbance_update_into,
    observer_inputs_into,
    pose_reference_into,
    station_errors,
    vehicle_objective_into,
    vehicle_wrench_into,
    velocity_law_into,
)

from conftest import signed_numbers


def same(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and a.tobytes() == b.tobytes()



def test_the_observer_inputs_are_numpys(rng):
    for _ in range(500):
        v, v0, dt = signed_numbers(rng, 11), signed_numbers(rng, 11), float(10.0 ** rng.uniform(-4, -1))
        acceleration, mean = np.empty(11), np.empty(11)
        observer_inputs_into(v, v0, dt, acceleration, mean)
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
        needed, applied0, applied, disturbance = (signed_numbers(rng, 6) for _ in range(4))
        gain = -np.expm1(-0.01 / float(rng.uniform(0.05, 1.0)))
        short = np.zeros(6) if trial % 2 else np.where(rng.random(6) < 0.5, signed_numbers(rng, 6), 0.0)
        old, new = numpy_disturbance(needed, applied0, applied, disturbance, gain, short), np.empty(6)
        disturbance_update_into(needed, applied0, applied, disturbance, gain, short, bool(short.any()), new)
        assert same(new, old)
        winding += int(np.sum(short * -gain * (needed - 0.5 * (applied0 + applied) - disturbance) > 0))
    assert winding > 100  # the back-calculation's branch was taken


def placements(rng: np.random.Generator, count: int):
    """Random placements, every other one the identity (the shipped vehicles' base frame)."""
    for trial in range(count):
        placement = pin.SE3.Random() if trial % 2 else pin.SE3.Identity()
        yield trial, placement, placement.rotation.copy(), placement.translation.copy()


def test_the_velocity_law_is_pinocchios_and_numpys(rng):
    """nu as base_twist computes it (Pinocchio's SE3.actInv of v's vehicle part), then numpy's PI law and the
    integral's step."""
    for _, placement, rotation, translation in placements(rng, 3000):
        reference, feedforward, kp, ki, integral, disturbance = (signed_numbers(rng, 6) for _ in range(6))
        v, dt = signed_numbers(rng, 11), float(10.0 ** rng.uniform(-3, -1))
        nu, error, wrench, integral_next = (np.empty(6) for _ in range(4))
        velocity_law_into(reference, v, rotation, translation, feedforward, kp, ki, integral, disturbance, dt, nu,
                          error, wrench, integral_next)
        old_nu = placement.actInv(pin.Motion(v[:6])).vector
        old_error = reference - old_nu
        assert same(nu, old_nu) and same(error, old_error)
        assert same(wrench, feedforward + kp * old_error + ki * integral - disturbance)
        assert same(integral_next, integral + dt * old_error)


def test_the_base_reference_and_its_rate_are_pinocchios_and_numpys_in_place(rng):
    rate = signed_numbers(rng, 6)
    old = rate.copy()
    for trial, placement, rotation, translation in placements(rng, 2000):
        reference, last, dt = signed_numbers(rng, 11), signed_numbers(rng, 6), float(10.0 ** rng.uniform(-3, -1))
        filtered, nu_ref = trial % 3 != 0, np.empty(6)
        base_reference_into(reference, rotation, translation, last, rate, dt, 0.1, filtered, nu_ref)
        old_nu_ref = placement.actInv(pin.Motion(reference[:6])).vector
        assert same(nu_ref, old_nu_ref)
        if filtered:
            step = (old_nu_ref - last) / dt
            old += (step - old) * dt / (0.1 + dt)
        assert same(rate, old)


def test_the_vehicle_rows_are_numpys_and_pinocchios(rng):
    """vehicle_inverse_dynamics's tail: numpy's products of Mbar's slices, then Pinocchio's SE3.actInv of the joint's
    force (any placement, the identity of the shipped vehicles included; arms of 0 to 6 joints); a base frame's rate
    mapped to the joint first as the feedforward did, base_placement.act(pin.Motion(rate))."""
    wrench = np.empty(6)
    for trial, placement, rotation, translation in placements(rng, 4000):
        n_arm = trial % 7
        mass, bias = rng.standard_normal((6 + n_arm, 6 + n_arm)) * 50.0, signed_numbers(rng, 6 + n_arm)
        base, arm = signed_numbers(rng, 6), signed_numbers(rng, n_arm)
        base_frame = trial % 4 == 1
        joint_rate = placement.act(pin.Motion(base)).vector if base_frame else base
        joint = mass[:6, :6] @ joint_rate + mass[:6, 6:] @ arm + bias[:6]
        old = placement.actInv(pin.Force(joint)).vector
        vehicle_wrench_into(mass, bias, base, arm, rotation, translation, base_frame, wrench)
        assert same(wrench, old)
    with pytest.raises(ValueError):
        vehicle_wrench_into(mass, bias, base[:3], arm, rotation, translation, False, wrench)


def test_the_station_errors_are_pinocchios_and_numpys(rng):
    """ActuatedKinematics.errors' numbers before the kernel: the base frame's pose oMi * joint_M_base (Pinocchio's
    product), |p_d - p| (numpy's sqrt of x.dot(x)) and the norm of Pinocchio's log3 of R^T R_d (numpy's @ of its
    column-major rotations)."""
    for trial, placement, _, _ in placements(rng, 3000):
        joint, target = pin.SE3.Random(), pin.SE3.Random()
        joint.translation, target.translation = signed_numbers(rng, 3), signed_numbers(rng, 3)
        if trial % 5 == 0:  # at the station: the attitude error exactly zero
            target = joint * placement
        pose = joint * placement
        distance, attitude = station_errors(joint.rotation, joint.translation, placement.rotation,
                                            placement.translation, target.rotation, target.translation)
        offset, log = target.translation - pose.translation, pin.log3(pose.rotation.T @ target.rotation)
        assert distance == np.sqrt(offset.dot(offset)) and type(distance) is float
        assert attitude == np.sqrt(log.dot(log)) and type(attitude) is float


def numpy_pose_reference(pose: pin.SE3, target: pin.SE3, gains: np.ndarray) -> np.ndarray:
    """pose_velocity_reference before the kernel."""
    world_to_body = pose.rotation.T
    position_error = world_to_body @ (target.translation - pose.translation)
    return gains * np.concatenate([position_error, pin.log3(world_to_body @ target.rotation)])


def test_the_pose_reference_is_pinocchios_and_numpys(rng):
    """pose_velocity_reference (and VehiclePoseController.reference through it) before the kernel: numpy's products of
    Pinocchio's rotations, pin.log3, the gains, then np.minimum(np.maximum(nu, -max_speed), max_speed) (signed zeros
    and bounds hit exactly included); a number broadcast as before."""
    bounded_hits = 0
    for trial in range(3000):
        pose, target = pin.SE3.Random(), pin.SE3.Random()
        pose.translation = signed_numbers(rng, 3)
        target.translation = pose.translation.copy() if trial % 7 == 0 else signed_numbers(rng, 3)
        if trial % 5 == 0:
            target.rotation = pose.rotation  # no attitude error: zeros
        gains, max_speed, out = np.abs(signed_numbers(rng, 6)), np.abs(signed_numbers(rng, 6)), np.empty(6)
        old = numpy_pose_reference(pose, target, gains)
        if trial % 2:
            max_speed[trial % 6] = abs(old[trial % 6])  # the bound met exactly
            pose_reference_into(pose.rotation, pose.translation, target.rotation, target.translation, gains,
                                max_speed, True, out)
            new = pose_velocity_reference(pose, target, gains, max_speed)
            old = np.minimum(np.maximum(old, -max_speed), max_speed)
            bounded_hits += int(np.any(np.abs(old) == max_speed))
        else:
            pose_reference_into(pose.rotation, pose.translation, target.rotation, target.translation, gains, gains,
                                False, out)
            new = pose_velocity_reference(pose, target, gains)
        assert same(out, old) and same(new, old)
    assert bounded_hits > 1000
    expected = np.minimum(np.maximum(numpy_pose_reference(pose, target, 0.5), -0.1), 0.1)
    assert same(pose_velocity_reference(pose, target, 0.5, 0.1), expected)
    assert same(VehiclePoseController(None, 0.5, 0.1).reference(pose, target), expected)
    assert same(VehiclePoseController(None, gains).reference(pose, target), numpy_pose_reference(pose, target, gains))


def test_the_arm_command_is_numpys_clip_lag_and_acceleration(rng):
    """CoordinatedControl.command's arm before the kernel: np.minimum(np.maximum(arm, -limit), limit), lag_command
    with the servo compensation, (command - rate) / tau; a NaN stays NaN (the plant refuses it), never a bound."""
    tau, dt = 0.1, 0.01
    lag = float(-np.expm1(-dt / np.asarray(tau)))
    for trial in range(3000):
        arm, rate = signed_numbers(rng, 5), signed_numbers(rng, 5)
        limit = np.abs(signed_numbers(rng, 5)) + 1e-3
        arm[trial % 5] = -limit[trial % 5] if trial % 2 else limit[trial % 5]  # at the bound exactly
        compensate = trial % 3 != 0
        clipped = np.minimum(np.maximum(arm, -limit), limit)
        old = lag_command(rate, clipped, dt, tau) if compensate else clipped
        command, acceleration = np.empty(5), np.empty(5)
        arm_command_into(arm, limit, rate, lag, compensate, tau, command, acceleration)
        assert same(command, old) and same(acceleration, (old - rate) / tau)
    arm[1] = np.nan
    arm_command_into(arm, limit, rate, lag, False, tau, command, acceleration)
    assert np.isnan(command[1]) and np.isnan(acceleration[1])


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
        out, placement = np.empty(6), plant.base_placement
        assert vehicle_inverse_dynamics(plant, q, v, base, arm, out=out) is out and same(out, old)
        kept = (placement.rotation.copy(), placement.translation.copy())  # C-ordered copies, as the controller keeps
        assert same(vehicle_inverse_dynamics(plant, q, v, base, arm, placement=kept), old)
        rate = placement.actInv(pin.Motion(base)).vector  # the base frame's rate whose joint rate is base
        assert np.allclose(vehicle_inverse_dynamics(plant, q, v, rate, arm, base_frame=True), old, atol=1e-9)


def numpy_ratio(asked: np.ndarray, achieved: np.ndarray, tolerance: float = 1e-6) -> np.ndarray:
    """achieved_ratio before the kernel."""
    scale = max(1.0, float(np.max(np.abs(asked))))
    short = np.abs(asked - achieved) > tolerance * scale
    ratio = np.ones(6)
    ratio[short] = np.clip(achieved[short] / np.where(asked[short] == 0.0, 1.0, asked[short]), 0.0, 1.0)
    return ratio


def test_the_achieved_ratio_is_numpys(rng):
    """Shortfalls of every sign, a zero asked, achieved exactly 0 or -0 or the asked value (the clip's ties), axes
    within the tolerance."""
    for trial in range(3000):
        asked, achieved = signed_numbers(rng, 6), signed_numbers(rng, 6)
        achieved[trial % 6] = asked[trial % 6] * (1.0 - 1e-12)  # within the tolerance: 1
        achieved[(trial + 1) % 6] = -0.0 if trial % 2 else 0.0
        asked[(trial + 2) % 6] = 0.0
        assert same(achieved_ratio(asked, achieved), numpy_ratio(asked, achieved))
        assert same(achieved_ratio(asked, achieved, 1e-3), numpy_ratio(asked, achieved, 1e-3))


def test_a_planar_vehicles_rows_take_a_base_frame_rate_as_its_joint_rate():
    """A planar base (no compiled rows): the base frame's rate (6,) mapped to the joint's (vx, vy, wz) first."""
    robot = uvms.load("hoang2011")
    plant = Plant(robot)
    q, v = robot.neutral(), np.linspace(0.1, 0.5, robot.nv)
    rate, arm = np.array([0.3, -0.2, 0.0, 0.0, 0.0, 0.7]), np.ones(robot.n_arm)
    joint = plant.base_placement.act(pin.Motion(rate)).vector[[0, 1, 5]]
    wrench = vehicle_inverse_dynamics(plant, q, v, rate, arm, base_frame=True)
    assert same(wrench, vehicle_inverse_dynamics(plant, q, v, joint, arm))
    assert wrench[2] == wrench[3] == wrench[4] == 0.0 and abs(wrench[5]) > 1.0


def test_the_vehicle_objective_is_pinocchios_and_numpys(rng):
    """ActuatedKinematics' pose objective before the kernel: the base frame's pose oMi * joint_M_base (Pinocchio's
    product), the pose controller's law (bounded by max_speed or not), np.clip to the thrusters' bounds (bounds met
    exactly and signed zeros included) and joint_M_base.act(Motion(nu)) (Pinocchio's)."""
    clipped_hits = 0
    for trial, placement, rotation, translation in placements(rng, 3000):
        joint, target = pin.SE3.Random(), pin.SE3.Random()
        joint.translation, target.translation = signed_numbers(rng, 3), signed_numbers(rng, 3)
        if trial % 5 == 0:
            target = joint * placement  # at the station: zeros
        gains, max_speed = np.abs(signed_numbers(rng, 6)), np.abs(signed_numbers(rng, 6))
        bounded, clip = trial % 3 == 0, trial % 4 != 0
        old = pose_velocity_reference(joint * placement, target, gains, max_speed if bounded else None)
        lower, upper = np.sort(np.stack([signed_numbers(rng, 6), signed_numbers(rng, 6)]), axis=0)
        lower[trial % 6] = old[trial % 6]  # a bound met exactly
        upper[trial % 6] = max(upper[trial % 6], old[trial % 6])
        if clip:
            clipped = np.clip(old, lower, upper)
            clipped_hits += int(np.any(clipped != old))
            old = clipped
        nu, joint_rates = np.empty(6), np.empty(6)
        vehicle_objective_into(joint.rotation, joint.translation, rotation, translation, target.rotation,
                               target.translation, gains, max_speed if bounded else gains, bounded, lower, upper,
                               clip, nu, joint_rates)
        assert same(nu, old) and same(joint_rates, placement.act(pin.Motion(old)).vector)
    assert clipped_hits > 1000
