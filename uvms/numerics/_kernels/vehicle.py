"""The vector arithmetic of the vehicle's velocity loop and disturbance observer
(:class:`uvms.control.vehicle.VehicleVelocityController`) and of the reference's rate
(:class:`uvms.control.coordination.CoordinatedControl`).

Each step of the loops combines vectors of 6-11 numbers in a handful of numpy operations, each dominated by its
dispatch; here each group is one compiled call. Every entry is computed with the operations of the numpy expressions
they replace, in their order (no fused multiply-add: numba contracts nothing without ``fastmath``; BLAS's products
as numba's ``np.dot``, numpy's on the same layouts; Pinocchio's SE3 arithmetic as :mod:`.pose` writes it out), so
the numbers are the same bit for bit. Each kernel writes into arrays its caller passes (a returned array costs numba
a boxing call per array): the caller's own buffers for what is read within the step, new arrays for what a record
keeps.

The module imports numba, so it is loaded where a vehicle loop first runs (an actuated run, whose plant loads it
anyway); its kernels compile at their first call and are cached on disk (``cache=True``, see
:mod:`uvms.numerics._kernels`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .dense import clip_into
from .pose import action_into, compose_into, inverse_action_into, log3_into

__all__ = ["achieved_ratio_into", "arm_command_into", "base_reference_into", "disturbance_update_into",
           "observer_inputs_into", "pose_reference_into", "station_errors", "vehicle_objective_into",
           "vehicle_wrench_into", "velocity_law_into"]


@njit(cache=True)
def vehicle_wrench_into(mass: np.ndarray, bias: np.ndarray, base_acceleration: np.ndarray,
                        arm_acceleration: np.ndarray, rotation: np.ndarray, translation: np.ndarray, base_frame: bool,
                        out: np.ndarray) -> None:
    """The body wrench (6,) [N, N m] at the base frame of the vehicle rows of the equations of motion, into ``out``:
    :func:`uvms.dynamics.plant.actuated.vehicle_inverse_dynamics`'s ``Mbar_bb a_b + Mbar_bm a_m + nbar_b`` (BLAS's
    products, as numpy's ``@`` on the same slices) mapped from the vehicle joint to the base frame as Pinocchio's
    ``SE3.actInv(Force)`` computes it: f' = R^T f, n' = R^T (n - p x f) (:func:`inverse_action_into`).

    Args:
        mass: Mbar (nv, nv); bias: nbar (nv,); base_acceleration: (6,) the vehicle's twist rate, the vehicle
        joint's (``base_frame`` False) or the base frame's (True: mapped to the joint first as Pinocchio's
        ``SE3.act(Motion)``, :func:`action_into`); arm_acceleration: (n_arm,); rotation: R (3, 3) and translation:
        p (3,) of joint_M_base; out: (6,) written.
    """
    joint_rate = np.empty(6)
    if base_frame:
        action_into(rotation, translation, base_acceleration[:3], base_acceleration[3:6], joint_rate)
    else:
        joint_rate[:] = base_acceleration
    # BLAS reads the slices as contiguous copies (what numba's np.dot does with a strided view, said here)
    vehicle, coupling = np.ascontiguousarray(mass[:6, :6]), np.ascontiguousarray(mass[:6, 6:])
    joint = np.dot(vehicle, joint_rate) + np.dot(coupling, arm_acceleration) + bias[:6]
    inverse_action_into(rotation, translation, joint[3:], joint[:3], out, 3, 0)


@njit(cache=True)
def observer_inputs_into(v: np.ndarray, v0: np.ndarray, dt: float, acceleration: np.ndarray,
                         mean: np.ndarray) -> None:
    """The measured acceleration (nv,) [m/s^2, rad/s^2] and the step's mean velocity (nv,) [m/s, rad/s] of the
    velocities v0, v (nv,) dt [s] apart, into ``acceleration`` and ``mean``: numpy's ``(v - v0) / dt`` and
    ``0.5 * (v0 + v)``."""
    for i in range(v.size):
        acceleration[i] = (v[i] - v0[i]) / dt
        mean[i] = 0.5 * (v0[i] + v[i])


@njit(cache=True)
def disturbance_update_into(needed: np.ndarray, applied0: np.ndarray, applied: np.ndarray, disturbance: np.ndarray,
                            gain: float, short: np.ndarray, falls_short: bool, out: np.ndarray) -> None:
    """The disturbance estimate d_hat (6,) [N, N m] after one step of the observer, into ``out``.

    d = needed - (applied0 + applied) / 2, update = gain (d - d_hat); without ``falls_short`` d_hat + update, else per
    axis d_hat + gain r where r (``short``, the last allocation's asked - achieved) and -update have the same sign,
    d_hat where r != 0, d_hat + update elsewhere (numpy's ``np.where`` of
    :meth:`uvms.control.vehicle.VehicleVelocityController.observe`).

    Args:
        needed: the model's wrench (6,) for the measured motion; applied0, applied: the actuators' wrench (6,) at the
            step's start and end; disturbance: d_hat (6,) now; gain: 1 - exp(-dt / T); short: r (6,);
            falls_short: r has a non-zero entry; out: (6,) written (not ``disturbance``'s array).
    """
    for i in range(6):
        update = gain * ((needed[i] - 0.5 * (applied0[i] + applied[i])) - disturbance[i])
        if falls_short:
            if short[i] * -update > 0.0:  # the wrench would grow where the allocation already fell short
                update = gain * short[i]
            elif short[i] != 0.0:
                update = 0.0
        out[i] = disturbance[i] + update


@njit(cache=True)
def velocity_law_into(reference: np.ndarray, v: np.ndarray, rotation: np.ndarray, translation: np.ndarray,
                      feedforward: np.ndarray, kp: np.ndarray, ki: np.ndarray, integral: np.ndarray,
                      disturbance: np.ndarray, dt: float, nu: np.ndarray, error: np.ndarray, wrench: np.ndarray,
                      integral_next: np.ndarray) -> None:
    """The PI law with feedforward of :meth:`uvms.control.vehicle.VehicleVelocityController.control`, each output
    (6,) written: nu the vehicle's body twist in its base frame [m/s, rad/s]
    (:func:`uvms.dynamics.plant.actuated.base_twist`: Pinocchio's ``SE3.actInv`` of v's vehicle part,
    :func:`inverse_action_into`), e = nu_ref - nu, tau = tau_model + Kp e + Ki integral - d_hat [N, N m] (numpy's
    ``feedforward + kp * error + ki * integral - disturbance``, its sums left to right) and the integral after the
    step where nothing falls short, integral + dt e [m, rad] (numpy's ``integral + dt * error``).

    Args:
        reference: nu_ref (6,); v: (nv,) the measured velocity, its vehicle part first (the joint's axes);
        rotation, translation: joint_M_base; feedforward: tau_model (6,); kp, ki: (6,); integral: (6,);
        disturbance: d_hat (6,); dt: the control period [s]; nu, error, wrench, integral_next: (6,) written.
    """
    inverse_action_into(rotation, translation, v[:3], v[3:6], nu, 0, 3)
    for i in range(6):
        error[i] = reference[i] - nu[i]
        wrench[i] = ((feedforward[i] + kp[i] * error[i]) + ki[i] * integral[i]) - disturbance[i]
        integral_next[i] = integral[i] + dt * error[i]


@njit(cache=True)
def base_reference_into(reference: np.ndarray, rotation: np.ndarray, translation: np.ndarray, last: np.ndarray,
                        rate: np.ndarray, dt: float, time_constant: float, filtered: bool, out: np.ndarray) -> None:
    """nu_ref (6,) [m/s, rad/s] into ``out``: the vehicle part of the kinematic reference (the joint's axes) in the
    base frame (Pinocchio's ``SE3.actInv`` of the motion, :func:`inverse_action_into`); with ``filtered`` the
    reference's rate (6,) [m/s^2, rad/s^2] is updated in place by one step of its first-order filter: rate +=
    ((nu_ref - last) / dt - rate) dt / (T + dt) (numpy's ``rate += (step - rate) * dt / (T + dt)`` with
    ``step = (nu_ref - last) / dt``).

    Args:
        reference: v_ref (nv,), its vehicle part first; rotation, translation: joint_M_base; last: nu_ref (6,) of the
            last step; rate: (6,); dt: the step [s]; time_constant: T [s] of the filter; filtered: update the rate;
            out: (6,) written.
    """
    inverse_action_into(rotation, translation, reference[:3], reference[3:6], out, 0, 3)
    if filtered:
        for i in range(6):
            rate[i] += ((out[i] - last[i]) / dt - rate[i]) * dt / (time_constant + dt)


@njit(cache=True)
def arm_command_into(arm: np.ndarray, limit: np.ndarray, rate: np.ndarray, lag: float, compensate: bool,
                     time_constant: float, command: np.ndarray, acceleration: np.ndarray) -> None:
    """The arm's command (n_arm,) and the acceleration it gives the servos the model knows, written:
    :meth:`uvms.control.coordination.CoordinatedControl.command`'s numpy expressions. The rates asked clipped to
    +-limit (``np.minimum(np.maximum(arm, -limit), limit)``: the second argument between equal numbers, NaN kept);
    with ``compensate`` the servos' lag inverted over the step, rate + (clipped - rate) / lag
    (:func:`uvms.dynamics.plant.actuated.lag_command`, lag = 1 - exp(-dt / tau)); acceleration = (command - rate) /
    tau.

    Args:
        arm: the rates asked (n_arm,) [rad/s or m/s]; limit: (n_arm,) > 0; rate: the joints' measured rates (n_arm,);
        lag: 1 - exp(-dt / tau); compensate: invert the lag; time_constant: tau [s]; command, acceleration:
        (n_arm,) written.
    """
    for i in range(arm.size):
        low, high, value = -limit[i], limit[i], arm[i]
        value = value if value > low or value != value else low  # np.maximum
        value = value if value < high or value != value else high  # np.minimum
        if compensate:
            value = rate[i] + (value - rate[i]) / lag
        command[i] = value
        acceleration[i] = (value - rate[i]) / time_constant


@njit(cache=True)
def pose_reference_into(rotation: np.ndarray, translation: np.ndarray, target_rotation: np.ndarray,
                        target_translation: np.ndarray, gains: np.ndarray, max_speed: np.ndarray, bounded: bool,
                        out: np.ndarray) -> None:
    """nu_ref (6,) [m/s, rad/s] = K_pose [R^T (p_d - p); log3(R^T R_d)] into ``out``, bounded to +-max_speed when
    ``bounded``: :func:`uvms.control.vehicle.pose_velocity_reference` (BLAS's products, numpy's ``@`` on the same
    layouts; Pinocchio's log3, :func:`log3_into`) and :meth:`~uvms.control.vehicle.VehiclePoseController.reference`'s
    bound (``np.minimum(np.maximum(nu, -max_speed), max_speed)``).

    Args:
        rotation, translation: the base frame's pose world_M_base (R (3, 3), p (3,)); target_rotation,
        target_translation: the pose wanted; gains: (6,) [1/s]; max_speed: (6,) [m/s, rad/s] (read when
        ``bounded``); out: (6,) written.
    """
    world_to_body = rotation.T
    position = np.dot(world_to_body, target_translation - translation)
    attitude = np.empty(3)
    log3_into(np.dot(world_to_body, target_rotation), attitude)
    for i in range(3):
        out[i] = gains[i] * position[i]
        out[3 + i] = gains[3 + i] * attitude[i]
    if bounded:
        for i in range(6):
            low, high, value = -max_speed[i], max_speed[i], out[i]
            value = value if value > low or value != value else low  # np.maximum
            out[i] = value if value < high or value != value else high  # np.minimum


@njit(cache=True)
def vehicle_objective_into(joint_rotation: np.ndarray, joint_translation: np.ndarray, placement_rotation: np.ndarray,
                           placement_translation: np.ndarray, target_rotation: np.ndarray,
                           target_translation: np.ndarray, gains: np.ndarray, max_speed: np.ndarray, bounded: bool,
                           lower: np.ndarray, upper: np.ndarray, clip: bool, nu: np.ndarray,
                           joint_rates: np.ndarray) -> None:
    """The vehicle's pose objective of :class:`uvms.control.station.ActuatedKinematics` in one call: the base frame's
    pose oMi * joint_M_base (Pinocchio's SE3 product, :func:`compose_into`), nu_pose towards the station
    (:func:`pose_reference_into`) into ``nu``, with ``clip`` bounded to [lower, upper] (``np.clip``'s numbers: max
    then min, a NaN kept, an entry equal to a bound giving the bound), and that twist in the vehicle joint's axes
    (Pinocchio's ``joint_M_base.act(Motion(nu))``, :func:`action_into`) into ``joint_rates``.

    Args:
        joint_rotation, joint_translation: the vehicle joint's placement oMi (3, 3), (3,); placement_rotation,
        placement_translation: joint_M_base; target_rotation, target_translation: the station (world_M_base);
        gains, max_speed, bounded: as :func:`pose_reference_into`; lower, upper: (6,) [m/s, rad/s] base frame (read
        when ``clip``); nu, joint_rates: (6,) written.
    """
    rotation, translation = np.empty((3, 3)).T, np.empty(3)  # Pinocchio's rotations are column-major (BLAS's layout)
    compose_into(joint_rotation, joint_translation, placement_rotation, placement_translation, rotation, translation)
    pose_reference_into(rotation, translation, target_rotation, target_translation, gains, max_speed, bounded, nu)
    if clip:
        clip_into(nu, lower, upper, nu)
    action_into(placement_rotation, placement_translation, nu[:3], nu[3:], joint_rates)


@njit(cache=True)
def station_errors(joint_rotation: np.ndarray, joint_translation: np.ndarray, placement_rotation: np.ndarray,
                   placement_translation: np.ndarray, target_rotation: np.ndarray,
                   target_translation: np.ndarray) -> tuple[float, float]:
    """(|p_d - p| [m], |log3(R^T R_d)| [rad]): the vehicle's distance from its station and its attitude error, of the
    base frame's pose (R, p) = oMi * joint_M_base (Pinocchio's SE3 product, :func:`compose_into`) and the station's
    (R_d, p_d): the expressions of :meth:`uvms.control.station.ActuatedKinematics.error_series` (BLAS's products as
    numpy's on the same layouts, Pinocchio's log3, numpy's sqrt of x.dot(x)).

    Args:
        joint_rotation, joint_translation: the vehicle joint's placement oMi (3, 3), (3,); placement_rotation,
        placement_translation: joint_M_base; target_rotation, target_translation: the station.
    """
    rotation, translation = np.empty((3, 3)).T, np.empty(3)  # Pinocchio's rotations are column-major (BLAS's layout)
    compose_into(joint_rotation, joint_translation, placement_rotation, placement_translation, rotation, translation)
    offset = target_translation - translation
    attitude = np.empty(3)
    log3_into(np.dot(rotation.T, target_rotation), attitude)
    return np.sqrt(np.dot(offset, offset)), np.sqrt(np.dot(attitude, attitude))


@njit(cache=True)
def achieved_ratio_into(asked: np.ndarray, achieved: np.ndarray, tolerance: float, out: np.ndarray) -> None:
    """r (6,) = clip(achieved / asked, 0, 1) on the axes where |asked - achieved| > tolerance max(1, |asked|_inf), 1
    elsewhere, into ``out``: :func:`uvms.control.coordination.achieved_ratio`'s numpy expressions (a zero asked read
    as 1; ``np.clip`` keeps its argument between equal numbers, unlike ``np.maximum``; NaN kept).

    Args:
        asked, achieved: the wrenches (6,) [N, N m]; tolerance: relative; out: (6,) written.
    """
    largest = 0.0
    for i in range(6):
        largest = max(largest, abs(asked[i]))
    scale = max(1.0, largest)
    for i in range(6):
        value = 1.0
        if abs(asked[i] - achieved[i]) > tolerance * scale:
            value = achieved[i] / (1.0 if asked[i] == 0.0 else asked[i])
            value = value if value >= 0.0 or value != value else 0.0  # np.clip keeps its argument between equals
            value = value if value <= 1.0 or value != value else 1.0  # (a -0 stays -0), NaN kept
        out[i] = value
