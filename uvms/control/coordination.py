"""Arm-vehicle coordination: the arm's part of a kinematic reference solved again with the MEASURED vehicle velocity.

A kinematic controller (CLIK, task priority) gives a generalized velocity reference v_ref = [nu_ref; qd_ref]
for vehicle and arm. The vehicle follows nu_ref only through its thrusters, with a lag and under
disturbances; the arm, much faster, can take up the difference. With J = [J_v | J_a] the task Jacobian
(world-aligned rows, columns in the order of v) and v_task = J v_ref what the reference asks of the task::

    qd_arm = J_a^# (v_task - J_v nu_measured)

(Simetti & Casalino's arm-vehicle coordination; HippoCampus' "manipulator compensation"). When the vehicle
does follow (nu_measured = nu_ref) and J_a has full row rank, qd_arm = qd_ref.

:class:`CoordinatedControl` puts it in the chain: kinematic layer -> arm command (coordinated: the arm solved
again through the scenario's solver with the vehicle level on top, :mod:`uvms.control.station`) and vehicle
velocity reference -> vehicle controller -> thrust allocation, with the allocation's shortfall fed back.

What keeps the objectives on the measured robot, not only on the reference (issue 48):

* the arm's servos (qdd = (u - qd) / tau) are inverted over the step (``servo_compensation``,
  :func:`uvms.dynamics.plant.actuated.lag_command`): the joints reach the re-solved rates one step after they
  were asked instead of tau later, so an objective that stops the arm (a pipe, the vehicle's own body) is not
  overrun by the servo's lag;
* the vehicle's velocity loop is given the reference's acceleration (``acceleration_feedforward``): the rate of
  nu_ref from consecutive commands, low-passed (:data:`REFERENCE_RATE_FILTER`), through the model's inertia
  (Mbar nu_ref' in the feedforward), so the vehicle follows a moving reference instead of trailing it by the PI
  loop's lag;
* the arm's speed limits are a level of the hierarchy (:class:`~uvms.control.station.ActuatedKinematics`): the
  task is scaled first when the arm cannot go faster, instead of the joint rates being clipped one by one after
  the solve (which turns the velocity away from what the objectives allow);
* every re-solve starts from the measured state, so the pose error the vehicle's lag has accumulated is in the
  task's error K e (the arm takes it up within its speed limits and the hierarchy's objectives).
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from ..dynamics.plant.actuated import base_twist
from ..dynamics.plant.command import Command, State
from ..dynamics.thrusters.fin_allocation import thruster_count
from ..errors import SolverInputError
from ..numerics._kernels import Kernel
from ..numerics.inverses import VariableDamping, damped_weighted_inverse
from ..robot.limits import Limit
from ..robot.robot import Robot
from .vehicle import LagFactor, VehicleVelocityController


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


#: A singular value of the arm's task Jacobian J_a below this fraction of its largest is a task direction the arm
#: cannot move (a singular arm, fewer joints than task rows, no arm); above it the arm is left to do the work.
ARM_RANK_TOLERANCE = 1e-6


def vehicle_rates_for_task(jacobian: np.ndarray, residual: np.ndarray, n_vehicle: int, *,
                           damping: float | VariableDamping = 0.0) -> np.ndarray:
    """dnu (n_vehicle,) [m/s, rad/s] the vehicle adds to give the part of a task velocity the arm cannot.

    The residual's part outside the range of the arm's columns J_a (judged at :data:`ARM_RANK_TOLERANCE`), r_v, is
    given by the vehicle, translation first and rotation only for what translation cannot do:
    dw = ((I - P_t) J_w)^# (I - P_t) r_v with P_t = J_t J_t^#, then dv = J_t^# (r_v - J_w dw). A point task moves
    the vehicle without turning it (a plain J_v^# would turn a vehicle whose task frame is off its origin); a task
    with orientation rows gets its rotation. What the arm could give but did not (its DLS damping) stays the arm's.

    Args:
        jacobian: J (k, nv) of the task, columns in the order of v (the vehicle joint's local twist [v; w] first).
        residual: r (k,) the task velocity still wanted [m/s, rad/s].
        n_vehicle: velocity entries of the vehicle (6).
        damping: DLS damping of the vehicle's inverses (fixed or variable).
    """
    residual = outside_range(jacobian[:, n_vehicle:]) @ residual  # what the arm cannot give
    translation, rotation = jacobian[:, :3], jacobian[:, 3:n_vehicle]
    outside = outside_range(translation)  # the rows translation cannot give
    turn_inverse, _, _ = damped_weighted_inverse(outside @ rotation, None, damping)
    turn = turn_inverse @ (outside @ residual)
    translation_inverse, _, _ = damped_weighted_inverse(translation, None, damping)  # (3, k)
    return np.concatenate([translation_inverse @ (residual - rotation @ turn), turn])


def outside_range(matrix: np.ndarray) -> np.ndarray:
    """P (k, k) the orthogonal projector onto the complement of the range of ``matrix`` (k, n), its rank judged at
    :data:`ARM_RANK_TOLERANCE` of its largest singular value; exactly zero for a full row rank (no rounding left
    for an inverse to blow up), the identity for no columns."""
    rows = matrix.shape[0]
    if not matrix.size:
        return np.eye(rows)
    u, singular, _ = np.linalg.svd(matrix)  # u (k, k)
    kept = int(np.sum(singular > ARM_RANK_TOLERANCE * singular[0])) if singular[0] > 0 else 0
    complement = u[:, kept:]
    return complement @ complement.T


#: The ratio of an allocation that gave what was asked (1 on every axis; read-only: shared by every step).
FULL_RATIO = np.ones(6)
FULL_RATIO.flags.writeable = False

#: Time constant [s] of the first-order filter on the reference's rate fed forward: the thrusters' (0.1 s on the
#: BlueROV2), so a step of the reference computed from the measured state (a saturation bound moving, an objective
#: activating) is not fed forward as a one-step spike (measured: unfiltered, the saturated-current intervention with
#: saturation feedback tilts 0.35 rad; filtered, 0.097).
REFERENCE_RATE_FILTER = 0.1


class KinematicLayer(Protocol):
    """What :class:`CoordinatedControl` asks of its kinematic layer
    (:class:`uvms.control.station.ActuatedKinematics`)."""

    def vehicle_objective(self, q: np.ndarray,
                          bounds: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray: ...

    def reference(self, t: float, q: np.ndarray,
                  bounds: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[np.ndarray, dict]: ...

    def arm_rates(self, t: float, q: np.ndarray, vehicle_velocity: np.ndarray) -> np.ndarray: ...

    def step_done(self) -> None: ...

    def error_series(self, t: np.ndarray, q: np.ndarray) -> dict[str, np.ndarray]: ...

    def reset(self, state: State, t: float = 0.0) -> None: ...


class CoordinatedControl:
    """The kinematic layer driving an actuated UVMS: the digital controller of an ``ActuatedPlant``
    (:func:`uvms.sim.loop.simulate`).

    Per step, from the measured (q, v): the kinematic reference v_ref = [nu_ref; qd_ref]
    (:meth:`uvms.control.station.ActuatedKinematics.reference`); the arm command qd_ref, or with
    ``coordination`` the arm solved again through the same solver with the measured vehicle velocity held
    (:meth:`~uvms.control.station.ActuatedKinematics.arm_rates`); nu_ref to the velocity loop (model feedforward
    + PI, the arm's commanded acceleration fed forward), its wrench through the allocation.

    Saturation feedback: when the allocation fell short on an axis i at the previous step (it gave
    w_achieved,i of the w_asked,i), the vehicle velocities the kinematic layer may ask this step are bounded
    between the measured nu_i and nu_i + r_i (nu_pose,i - nu_i), r_i = clip(w_achieved,i / w_asked,i, 0, 1):
    the vehicle level of the hierarchy asks what the thrusters can give, and the task below it (the arm) takes
    up the rest instead of the vehicle reference winding up.

    Args:
        robot: a floating-base Robot (the controller's kinematics).
        velocity: the vehicle velocity controller (its model and allocation).
        kinematic: the kinematic layer (an ActuatedKinematics: ``reference``, ``coordinated``, ``error_series``).
        dt: control period [s] (the simulation step).
        coordination: re-solve the arm with the measured vehicle velocity.
        saturation_feedback: bound the vehicle's part of the reference by what the allocation achieved.
        max_arm_rate: bound on every joint rate asked [rad/s or m/s] (None: the model's velocity limits).
        acceleration_feedforward: feed the reference's acceleration (nu_ref of this step minus the last, over dt)
            through the model's inertia (module docstring).
        servo_compensation: send the arm's servos the command that reaches the joint rates asked at the step's
            end (:func:`uvms.dynamics.plant.actuated.lag_command`, the model's ``motor_time_constant``); else the
            rates themselves.

    Raises:
        SolverInputError: a non-floating base, dt <= 0.
    """

    def __init__(self, robot: Robot, velocity: VehicleVelocityController, kinematic: KinematicLayer, dt: float, *,
                 coordination: bool = True, saturation_feedback: bool = False,
                 max_arm_rate: float | None = None, acceleration_feedforward: bool = True,
                 servo_compensation: bool = True) -> None:
        if robot.base_type != "floating":
            raise SolverInputError(f"an actuated UVMS needs a floating base, {robot.name} is {robot.base_type}")
        if not (np.isfinite(dt) and dt > 0):
            raise SolverInputError(f"dt must be a control period > 0 s, got {dt!r}")
        self.robot, self.velocity, self.kinematic, self.dt = robot, velocity, kinematic, float(dt)
        self.coordination, self.saturation_feedback = bool(coordination), bool(saturation_feedback)
        self.max_arm_rate = Limit.joint_velocities(robot).upper if max_arm_rate is None \
            else np.full(robot.n_arm, float(max_arm_rate))
        self.acceleration_feedforward = bool(acceleration_feedforward)
        self.servo_compensation = bool(servo_compensation)
        from ..numerics._kernels.vehicle import arm_command_into, base_reference_into  # numba: with the controller

        self._base_reference, self._arm_command = base_reference_into, arm_command_into
        self._sizes = robot.n_vehicle, robot.n_arm  # the model's (its properties cost a call each)
        self._arm_acceleration = np.empty(robot.n_arm)  # read within a step only (by the velocity loop)
        self._lag = LagFactor()  # the servos' lag over the control period
        self._thrusters = thruster_count(velocity.allocator)  # an allocation's variables: thrusts, then fin angles
        self._forget()

    def _forget(self) -> None:
        """Forget the last step: the allocation's ratio, the last reference."""
        self.ratio = FULL_RATIO  # achieved / asked wrench per axis at the last step (1: the allocation gave it)
        self._last_reference: np.ndarray | None = None  # nu_ref (6,) of the last step, base frame
        self._rate = np.zeros(6)  # nu_ref' (6,) filtered [m/s^2, rad/s^2]
        self._achieved = np.zeros(6)  # the allocation's achieved wrench at the last step [N, N m]
        placement = self.velocity.model.robot.base_placement  # joint_M_base (the property copies it per read)
        self._placement = (placement.rotation.copy(), placement.translation.copy())  # read as arrays

    def vehicle_bounds(self, nu: np.ndarray, nu_pose: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper) (6,) [m/s, rad/s] base frame: between the measured nu and nu + r (nu_pose - nu)."""
        reachable = nu + self.ratio * (nu_pose - nu)
        return np.minimum(nu, reachable), np.maximum(nu, reachable)

    def reset(self, state: State, t: float = 0.0) -> None:
        """A run from ``state``, the station (the vehicle held at its pose there): the velocity loop's integral
        zeroed and its gains not given derived there, the last allocation's shortfall and reference forgotten."""
        self._forget()
        self.velocity.reset(state.q)
        self.kinematic.reset(state, t)

    def derived_series(self, t: np.ndarray, q: np.ndarray) -> dict[str, np.ndarray]:
        """The series of the run derived after the loop from its stored rows t (N,) [s] and q (N, nq), not per step:
        the vehicle's and the end effector's errors (:meth:`uvms.control.station.ActuatedKinematics.error_series`)."""
        return self.kinematic.error_series(t, q)

    def command(self, state: State, t: float) -> Command:
        """The arm, thrust and fin commands for the step from the measured (q, v) at t [s]; advances the velocity
        loop's integral."""
        q, v = state.q, state.v
        (nb, n_arm), model = self._sizes, self.velocity.model
        terms = None  # the model at the measured state, evaluated with the observer's (the feedforward reads it)
        if self.velocity.disturbance_time_constant > 0.0:  # the last step's mismatch, from what the actuators gave
            applied = self._achieved if state.thrusts is None else \
                self.velocity.applied_wrench(q, v, state.thrusts, state.fins)
            terms = self.velocity.observe(q, v, applied, self.dt)
        bounds = None
        if self.saturation_feedback and self.ratio is not FULL_RATIO and (self.ratio < 1.0).any():
            nu = base_twist(model, v)
            bounds = self.vehicle_bounds(nu, self.kinematic.vehicle_objective(q))
        if self.coordination:  # the arm solved again with the measured vehicle velocity, at the same configuration
            reference, arm = self.kinematic.coordinated(t, q, v[:nb], bounds)
        else:
            reference, _ = self.kinematic.reference(t, q, bounds)
            arm = reference[nb:]
        self.kinematic.step_done()
        # the rates clipped to the arm's speed limits, the servos' lag inverted over the step
        # (:func:`~uvms.dynamics.plant.actuated.lag_command`) and the acceleration the servo the model knows gives
        # (its feedforward) in one compiled call, numpy's numbers
        command, tau = np.empty(n_arm), model.motor_time_constant
        self._arm_command(arm, self.max_arm_rate, v[nb:], self._lag(self.dt, tau), self.servo_compensation, tau,
                          command, self._arm_acceleration)
        # nu_ref (vehicle joint -> base frame) and the reference's rate over the last step, filtered (in place), in
        # one compiled call (Pinocchio's and numpy's numbers); nu_ref a new array (the row and the next step keep it)
        filtered = self.acceleration_feedforward and self._last_reference is not None
        nu_ref = np.empty(6)
        self._base_reference(reference, *self._placement, self._last_reference if filtered else self._rate,
                             self._rate, self.dt, REFERENCE_RATE_FILTER, filtered, nu_ref)
        rate = self._rate if filtered else None
        self._last_reference = nu_ref
        control = self.velocity.control(q, v, nu_ref, self.dt, reference_rate=rate,
                                        arm_acceleration=self._arm_acceleration, terms=terms)
        allocation = control.allocation
        self._achieved = allocation.achieved_wrench  # the observer's stand-in for a state without thrusts
        self.ratio = FULL_RATIO if allocation.attainable else achieved_ratio(control.wrench,
                                                                                allocation.achieved_wrench)
        # the integral and the estimate are new arrays at every step (never changed in place): kept as they are
        info = {"wrench_command": control.wrench, "achieved_wrench": allocation.achieved_wrench,
                "attainable": allocation.attainable, "velocity_integral": self.velocity.integral,
                "disturbance_estimate": self.velocity.disturbance,
                "nu_ref": nu_ref}
        actuators, n = allocation.thrusts, self._thrusters
        return Command(arm=command, thrust=actuators[:n], fins=actuators[n:], info=info)


def achieved_ratio(asked: np.ndarray, achieved: np.ndarray, tolerance: float = 1e-6) -> np.ndarray:
    """r (6,) = clip(achieved / asked, 0, 1) per wrench axis [N, N m], 1 where the allocation gave what was asked
    (within ``tolerance`` of max(1, |asked|_inf)); a new array, one compiled call
    (:func:`uvms.numerics._kernels.vehicle.achieved_ratio_into`)."""
    ratio = np.empty(6)
    (_ACHIEVED_RATIO.function or _ACHIEVED_RATIO.load())(np.asarray(asked, dtype=float),
                                                         np.asarray(achieved, dtype=float), float(tolerance), ratio)
    return ratio


#: numba loaded at the first shortfall.
_ACHIEVED_RATIO = Kernel("vehicle", "achieved_ratio_into")
