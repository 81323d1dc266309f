"""Arm-vehicle coordination: the arm's part of a kinematic reference solved again with the MEASURED vehicle velocity.

A kinematic controller (CLIK, task priority) gives a generalized velocity reference v_ref = [nu_ref; qd_ref]
for vehicle and arm. The vehicle follows nu_ref only through its thrusters, with a lag and under
disturbances; the arm, much faster, can take up the difference. With J = [J_v | J_a] the task Jacobian
(world-aligned rows, columns in the order of v) and v_task = J v_ref what the reference asks of the task::

    qd_arm = J_a^# (v_task - J_v nu_measured)

(Simetti & Casalino's arm-vehicle coordination; HippoCampus' "manipulator compensation"). When the vehicle
does follow (nu_measured = nu_ref) and J_a has full row rank, qd_arm = qd_ref.

:class:`CoordinatedControl` puts it in the chain: kinematic controller -> arm command (coordinated or not)
and vehicle velocity reference -> vehicle controller -> thrust allocation.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pinocchio as pin

from ..dynamics.actuated import ActuatedCommand
from ..errors import SolverInputError
from ..robot.limits import Limit
from ..robot.robot import Robot
from ..numerics.inverses import VariableDamping, damped_weighted_inverse
from .vehicle import VehicleVelocityController

#: A kinematic controller: (t [s], q (nq,), None) -> (v_ref (nv,), diagnostics), as ``uvms.sim.system.Controller``.
KinematicController = Callable[[float, np.ndarray, None], tuple[np.ndarray, object]]


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
    return arm_rates_for_task(jacobian, task, measured_vehicle_velocity, n_vehicle, weights=weights, damping=damping)


def arm_rates_for_task(jacobian: np.ndarray, task: np.ndarray, vehicle_velocity: np.ndarray, n_vehicle: int, *,
                       weights: np.ndarray | None = None, damping: float | VariableDamping = 0.0) -> np.ndarray:
    """qd_arm = J_a^# (task - J_v nu) (n_arm,): the arm's part of a task velocity (k,) with the vehicle's given.

    Args:
        jacobian: J (k, nv) of the task; task: the task velocity wanted (k,); vehicle_velocity: nu (n_vehicle,)
            in the axes of v; n_vehicle, weights, damping: as in :func:`coordinated_arm_rates`.
    """
    inverse, _, _ = damped_weighted_inverse(jacobian[:, n_vehicle:], weights, damping)  # (n_arm, k)
    return inverse @ (task - jacobian[:, :n_vehicle] @ vehicle_velocity)


class CoordinatedControl:
    """A kinematic controller driving an actuated UVMS: the digital controller of
    an ``ActuatedPlant`` (:func:`uvms.sim.loop.simulate`).

    Per step, from the measured (q, v): the kinematic controller's reference v_ref = [nu_ref; qd_ref];
    the arm command qd_ref, or with ``coordination`` the arm solved again with the measured vehicle velocity
    (:func:`coordinated_arm_rates` on the task Jacobian); the vehicle part nu_ref to the velocity loop
    (model feedforward + PI, the arm's commanded acceleration fed forward), its wrench through the allocation.

    Args:
        robot: a floating-base Robot (the controller's kinematics).
        velocity: the vehicle velocity controller (its model and allocation).
        kinematic: (t, q, None) -> (v_ref (nv,), diagnostics), the signature of every kinematic controller
            (``uvms.sim.system.Controller``: CLIK, task priority, set-based...); v_ref's vehicle part in the
            axes of v (the vehicle joint's local twist).
        dt: control period [s] (the simulation step).
        task_jacobian: q -> J (k, nv) of the task the arm keeps with coordination (world-aligned rows).
        coordination: re-solve the arm with the measured vehicle velocity.
        arm_damping: DLS damping of J_a^# [same units as J].
        max_arm_rate: bound on every joint command [rad/s or m/s] (None: the model's velocity limits).
        monitor: q -> {name: value} recorded per row (e.g. the vehicle and end-effector errors).

    Raises:
        SolverInputError: a non-floating base, dt <= 0.
    """

    def __init__(self, robot: Robot, velocity: VehicleVelocityController, kinematic: KinematicController, dt: float,
                 *, task_jacobian: Callable[[np.ndarray], np.ndarray], coordination: bool = True,
                 arm_damping: float = 0.01, max_arm_rate: float | None = None,
                 monitor: Callable[[np.ndarray], dict] | None = None) -> None:
        if robot.base_type != "floating":
            raise SolverInputError(f"an actuated UVMS needs a floating base, {robot.name} is {robot.base_type}")
        if not (np.isfinite(dt) and dt > 0):
            raise SolverInputError(f"dt must be a control period > 0 s, got {dt!r}")
        self.robot, self.velocity, self.kinematic, self.dt = robot, velocity, kinematic, float(dt)
        self.task_jacobian, self.monitor = task_jacobian, monitor
        self.coordination, self.arm_damping = bool(coordination), float(arm_damping)
        self.max_arm_rate = Limit.joint_velocities(robot).upper if max_arm_rate is None \
            else np.full(robot.n_arm, float(max_arm_rate))

    def arm_command(self, q: np.ndarray, v: np.ndarray, reference: np.ndarray) -> np.ndarray:
        """The joint-rate command (n_arm,): qd_ref, or coordinated with the measured vehicle, bounded."""
        nb = self.robot.n_vehicle
        if self.coordination:
            arm = coordinated_arm_rates(self.task_jacobian(q), reference, v[:nb], nb, damping=self.arm_damping)
        else:
            arm = reference[nb:]
        return np.clip(arm, -self.max_arm_rate, self.max_arm_rate)

    def __call__(self, t: float, q: np.ndarray, v: np.ndarray, thrusts: np.ndarray) -> ActuatedCommand:
        """The arm and thrust commands for the step from (t, q, v); advances the velocity loop's integral."""
        nb, model = self.robot.n_vehicle, self.velocity.model
        reference, _ = self.kinematic(t, q, None)
        arm = self.arm_command(q, v, reference)
        nu_ref = model._base_placement.actInv(pin.Motion(reference[:nb])).vector  # vehicle joint -> base frame
        arm_acceleration = (arm - v[nb:]) / model.motor_time_constant  # the servo the model knows
        control = self.velocity.control(q, v, nu_ref, self.dt, arm_acceleration=arm_acceleration)
        info = {"wrench_command": control.wrench, "achieved_wrench": control.allocation.achieved_wrench,
                "attainable": control.allocation.attainable, "velocity_integral": self.velocity.integral.copy()}
        if self.monitor is not None:
            info.update(self.monitor(q))
        return ActuatedCommand(arm, control.allocation.thrusts, info)
