"""The vector arithmetic of the vehicle's velocity loop and disturbance observer
(:class:`uvms.control.vehicle.VehicleVelocityController`) and of the reference's rate
(:class:`uvms.control.coordination.CoordinatedControl`).

Each step of the loops combines vectors of 6-11 numbers in a handful of numpy operations, each dominated by its
dispatch; here each group is one compiled call. Every entry is computed with the operations of the numpy expressions
they replace, in their order (no fused multiply-add: numba contracts nothing without ``fastmath``), so the numbers
are the same bit for bit.

The module imports numba, so it is loaded where a vehicle loop first runs (an actuated run, whose plant loads it
anyway); its kernels compile at their first call and are cached on disk (``cache=True``, see
:mod:`uvms.numerics._kernels`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .pose import inverse_action_into

__all__ = ["base_reference", "disturbance_update", "observer_inputs", "station_errors", "vehicle_wrench",
           "velocity_wrench"]


@njit(cache=True)
def vehicle_wrench(mass: np.ndarray, bias: np.ndarray, base_acceleration: np.ndarray, arm_acceleration: np.ndarray,
                   rotation: np.ndarray, translation: np.ndarray) -> np.ndarray:
    """The body wrench (6,) [N, N m] at the base frame of the vehicle rows of the equations of motion:
    :func:`uvms.dynamics.plant.actuated.vehicle_inverse_dynamics`'s ``Mbar_bb a_b + Mbar_bm a_m + nbar_b`` (BLAS's
    products, as numpy's ``@`` on the same slices) mapped from the vehicle joint to the base frame as Pinocchio's
    ``SE3.actInv(Force)`` computes it: f' = R^T f, n' = R^T (n - p x f), each entry's sums in Eigen's order (its
    numbers, signed zeros included).

    Args:
        mass: Mbar (nv, nv); bias: nbar (nv,); base_acceleration: (6,) the vehicle joint's twist rate;
        arm_acceleration: (n_arm,); rotation: R (3, 3) and translation: p (3,) of joint_M_base.
    """
    # BLAS reads the slices as contiguous copies (what numba's np.dot does with a strided view, said here)
    vehicle, coupling = np.ascontiguousarray(mass[:6, :6]), np.ascontiguousarray(mass[:6, 6:])
    joint = np.dot(vehicle, base_acceleration) + np.dot(coupling, arm_acceleration) + bias[:6]
    wrench = np.empty(6)
    inverse_action_into(rotation, translation, joint[3:], joint[:3], wrench, 3, 0)
    return wrench


@njit(cache=True)
def observer_inputs(v: np.ndarray, v0: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """(the measured acceleration (nv,) [m/s^2, rad/s^2], the step's mean velocity (nv,) [m/s, rad/s]) of the
    velocities v0, v (nv,) dt [s] apart: numpy's ``(v - v0) / dt`` and ``0.5 * (v0 + v)``."""
    acceleration, mean = np.empty(v.size), np.empty(v.size)
    for i in range(v.size):
        acceleration[i] = (v[i] - v0[i]) / dt
        mean[i] = 0.5 * (v0[i] + v[i])
    return acceleration, mean


@njit(cache=True)
def disturbance_update(needed: np.ndarray, applied0: np.ndarray, applied: np.ndarray, disturbance: np.ndarray,
                       gain: float, short: np.ndarray, falls_short: bool) -> np.ndarray:
    """The disturbance estimate d_hat (6,) [N, N m] after one step of the observer.

    d = needed - (applied0 + applied) / 2, update = gain (d - d_hat); without ``falls_short`` d_hat + update, else per
    axis d_hat + gain r where r (``short``, the last allocation's asked - achieved) and -update have the same sign,
    d_hat where r != 0, d_hat + update elsewhere (numpy's ``np.where`` of
    :meth:`uvms.control.vehicle.VehicleVelocityController.observe`).

    Args:
        needed: the model's wrench (6,) for the measured motion; applied0, applied: the actuators' wrench (6,) at the
            step's start and end; disturbance: d_hat (6,) now; gain: 1 - exp(-dt / T); short: r (6,);
            falls_short: r has a non-zero entry.
    """
    out = np.empty(6)
    for i in range(6):
        update = gain * ((needed[i] - 0.5 * (applied0[i] + applied[i])) - disturbance[i])
        if falls_short:
            if short[i] * -update > 0.0:  # the wrench would grow where the allocation already fell short
                update = gain * short[i]
            elif short[i] != 0.0:
                update = 0.0
        out[i] = disturbance[i] + update
    return out


@njit(cache=True)
def velocity_wrench(reference: np.ndarray, v: np.ndarray, rotation: np.ndarray, translation: np.ndarray,
                    feedforward: np.ndarray, kp: np.ndarray, ki: np.ndarray, integral: np.ndarray,
                    disturbance: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(nu, e = nu_ref - nu, tau = tau_model + Kp e + Ki integral - d_hat), each (6,) [m/s, rad/s] and [N, N m]: the
    PI law with feedforward of :meth:`uvms.control.vehicle.VehicleVelocityController.control` (numpy's
    ``feedforward + kp * error + ki * integral - disturbance``, its sums left to right), nu the vehicle's body twist
    in its base frame (:func:`uvms.dynamics.plant.actuated.base_twist`: Pinocchio's ``SE3.actInv`` of v's vehicle
    part, :func:`inverse_action_into`).

    Args:
        reference: nu_ref (6,); v: (nv,) the measured velocity, its vehicle part first (the joint's axes);
        rotation, translation: joint_M_base; feedforward: tau_model (6,); kp, ki: (6,); integral: (6,);
        disturbance: d_hat (6,).
    """
    nu, error, wrench = np.empty(6), np.empty(6), np.empty(6)
    inverse_action_into(rotation, translation, v[:3], v[3:6], nu, 0, 3)
    for i in range(6):
        error[i] = reference[i] - nu[i]
        wrench[i] = ((feedforward[i] + kp[i] * error[i]) + ki[i] * integral[i]) - disturbance[i]
    return nu, error, wrench


@njit(cache=True)
def base_reference(reference: np.ndarray, rotation: np.ndarray, translation: np.ndarray, last: np.ndarray,
                   rate: np.ndarray, dt: float, time_constant: float, filtered: bool) -> np.ndarray:
    """nu_ref (6,) [m/s, rad/s]: the vehicle part of the kinematic reference (the joint's axes) in the base frame
    (Pinocchio's ``SE3.actInv`` of the motion, :func:`inverse_action_into`); with ``filtered`` the reference's rate
    (6,) [m/s^2, rad/s^2] is updated in place by one step of its first-order filter: rate += ((nu_ref - last) / dt -
    rate) dt / (T + dt) (numpy's ``rate += (step - rate) * dt / (T + dt)`` with ``step = (nu_ref - last) / dt``).

    Args:
        reference: v_ref (nv,), its vehicle part first; rotation, translation: joint_M_base; last: nu_ref (6,) of the
            last step; rate: (6,); dt: the step [s]; time_constant: T [s] of the filter; filtered: update the rate.
    """
    nu_ref = np.empty(6)
    inverse_action_into(rotation, translation, reference[:3], reference[3:6], nu_ref, 0, 3)
    if filtered:
        for i in range(6):
            rate[i] += ((nu_ref[i] - last[i]) / dt - rate[i]) * dt / (time_constant + dt)
    return nu_ref


@njit(cache=True)
def station_errors(rotation: np.ndarray, translation: np.ndarray, target_rotation: np.ndarray,
                   target_translation: np.ndarray) -> tuple[np.ndarray, float]:
    """(R^T R_d (3, 3), |p_d - p| [m]): the vehicle's attitude error as a rotation (its log is the error in body
    axes) and its distance from the station, of the pose (R (3, 3), p (3,)) and the station's (R_d, p_d):
    :meth:`uvms.control.station.ActuatedKinematics.errors`' numpy expressions (BLAS's products, as ``@`` and
    ``dot``; ``sqrt``)."""
    offset = target_translation - translation
    return np.dot(rotation.T, target_rotation), np.sqrt(np.dot(offset, offset))
