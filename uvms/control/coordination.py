"""Arm-vehicle coordination: the arm's part of a kinematic reference solved again with the MEASURED vehicle velocity.

A kinematic controller (CLIK, task priority) gives a generalized velocity reference v_ref = [nu_ref; qd_ref]
for vehicle and arm. The vehicle follows nu_ref only through its thrusters, with a lag and under
disturbances; the arm, much faster, can take up the difference. With J = [J_v | J_a] the task Jacobian
(world-aligned rows, columns in the order of v) and v_task = J v_ref what the reference asks of the task::

    qd_arm = J_a^# (v_task - J_v nu_measured)

(Simetti & Casalino's arm-vehicle coordination; HippoCampus' "manipulator compensation"). When the vehicle
does follow (nu_measured = nu_ref) and J_a has full row rank, qd_arm = qd_ref.
"""

from __future__ import annotations

import numpy as np

from ..solvers.inverses import VariableDamping, damped_weighted_inverse


def coordinated_arm_rates(
    jacobian: np.ndarray,
    reference: np.ndarray,
    measured_vehicle_velocity: np.ndarray,
    n_vehicle: int,
    *,
    weights: np.ndarray | None = None,
    damping: float | VariableDamping = 0.0,
) -> np.ndarray:
    """The arm rates (n_arm,) that give the task velocity of ``reference`` with the vehicle as measured.

    Args:
        jacobian: J (k, nv) of the task (e.g. ``robot.jacobian(q, frame)[:3]`` for a point).
        reference: v_ref (nv,) the kinematic controller's generalized velocity [m/s, rad/s].
        measured_vehicle_velocity: nu (n_vehicle,), in the axes of v (the vehicle joint's local twist).
        n_vehicle: velocity entries of the vehicle.
        weights: arm joint weights W (n_arm,) or (n_arm, n_arm) (None: identity).
        damping: DLS damping of J_a^# (fixed or variable; 0: the pseudo-inverse).

    Returns:
        qd_arm = J_a^# (J v_ref - J_v nu) [rad/s or m/s].
    """
    task = jacobian @ reference  # (k,) what the reference asks of the task
    inverse, _, _ = damped_weighted_inverse(jacobian[:, n_vehicle:], weights, damping)  # (n_arm, k)
    return inverse @ (task - jacobian[:, :n_vehicle] @ measured_vehicle_velocity)
