"""Vehicle control: a body-velocity PI controller with Fossen model feedforward, and a pose controller on top.

Velocity loop (body FLU at the vehicle's base frame, nu = [v; w] [m/s, rad/s])::

    tau = tau_model + Kp (nu_ref - nu) + Ki integral(nu_ref - nu)
    tau_model = vehicle rows of Mbar [nu_ref'; a_m] + nbar(q, v)   (the plant's own model)

tau_model is :func:`uvms.dynamics.actuated.vehicle_inverse_dynamics` of a *model* plant (the controller's
knowledge: rigid-body + added-mass inertia, Coriolis, damping, restoring; usually no current, which the
integral learns). With ``arm_feedforward`` the arm's measured velocity and commanded acceleration go in too,
so the arm's reaction wrench is compensated before it moves the vehicle; without it, the model sees the arm
at rest. tau goes through the thrust allocation; the integral is frozen on the axes where the allocation
could not give the wrench and the error would push further into the limits (conditional integration,
anti-windup).

Pose loop: pose error -> body velocity reference, world-to-body rotation written out::

    nu_ref = K_pose [R^T (p_d - p); log3(R^T R_d)],   R = world_R_body
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..dynamics.actuated import base_twist, vehicle_inverse_dynamics
from ..dynamics.allocation import AllocationResult, ThrustAllocator
from ..dynamics.plant import Plant
from ..errors import SolverInputError


def gain_vector(value: float | np.ndarray, what: str, size: int = 6) -> np.ndarray:
    """A diagonal gain (size,) >= 0 from a number or ``size`` numbers.

    Raises:
        SolverInputError: not finite, negative or of the wrong size.
    """
    array = np.broadcast_to(np.asarray(value, dtype=float), (size,)).copy() if np.ndim(value) == 0 \
        else np.asarray(value, dtype=float)
    if array.shape != (size,) or not np.all(np.isfinite(array)) or np.any(array < 0):
        raise SolverInputError(f"{what} must be a number or {size} numbers >= 0 (a diagonal gain), got {value!r}")
    return array


def pose_velocity_reference(pose: pin.SE3, target: pin.SE3, gains: np.ndarray) -> np.ndarray:
    """Body velocity reference nu_ref (6,) [m/s, rad/s] that moves the base frame ``pose`` to ``target``.

    Args:
        pose: world_M_body now; target: world_M_body wanted; gains: (6,) [1/s] diagonal K_pose.

    Returns:
        K_pose [R^T (p_d - p); log3(R^T R_d)]: the position error rotated from world to body axes, the
        attitude error as a body rotation vector.
    """
    world_to_body = pose.rotation.T
    position_error = world_to_body @ (target.translation - pose.translation)  # body axes
    attitude_error = pin.log3(world_to_body @ target.rotation)  # body axes
    return gains * np.concatenate([position_error, attitude_error])


@dataclass(frozen=True)
class VehicleControl:
    """One output of the vehicle controller.

    Attributes:
        wrench: tau (6,) [N, N m] asked of the thrusters (body FLU at the base frame).
        feedforward: tau_model (6,) [N, N m]; allocation: what the thrusters give for tau.
        velocity_error: nu_ref - nu (6,) [m/s, rad/s].
    """

    wrench: np.ndarray
    feedforward: np.ndarray
    allocation: AllocationResult
    velocity_error: np.ndarray


class VehicleVelocityController:
    """Body-velocity PI control of the vehicle with model feedforward, through the thrust allocation.

    Args:
        model: the controller's model of the UVMS (a Plant; e.g. the true one without the current).
        allocator: the thrust allocation.
        kp: (6,) or a number [N s/m, N m s/rad] proportional gains.
        ki: (6,) or a number [N/m, N m/rad] integral gains.
        arm_feedforward: feed the arm's reaction forward (module docstring).

    Raises:
        SolverInputError: bad gains; an allocator with another number of rows.
    """

    def __init__(self, model: Plant, allocator: ThrustAllocator, kp: float | np.ndarray, ki: float | np.ndarray,
                 *, arm_feedforward: bool = True) -> None:
        if model.nb != 6:
            raise SolverInputError(f"vehicle control needs a floating base (6 body velocities), "
                                   f"{model.robot.name} has {model.nb}")
        self.model, self.allocator = model, allocator
        self.kp, self.ki = gain_vector(kp, "kp"), gain_vector(ki, "ki")
        self.arm_feedforward = bool(arm_feedforward)
        self.integral = np.zeros(6)  # integral of the velocity error [m, rad]

    def reset(self) -> None:
        """Zero the integral."""
        self.integral = np.zeros(6)

    def feedforward(self, q: np.ndarray, v: np.ndarray, reference_rate: np.ndarray,
                    arm_acceleration: np.ndarray) -> np.ndarray:
        """tau_model (6,) [N, N m]: the model's wrench for the vehicle rate ``reference_rate`` (6,), body FLU."""
        model = self.model
        base_rate = model._base_placement.act(pin.Motion(reference_rate)).vector  # base frame -> vehicle joint
        if not self.arm_feedforward:
            v = np.concatenate([v[:6], np.zeros(model.n_arm)])
            arm_acceleration = np.zeros(model.n_arm)
        return vehicle_inverse_dynamics(model, q, v, base_rate, arm_acceleration)

    def control(self, q: np.ndarray, v: np.ndarray, reference: np.ndarray, dt: float, *,
                reference_rate: np.ndarray | None = None, arm_acceleration: np.ndarray | None = None) -> VehicleControl:
        """The wrench and thrusts for one control period ``dt`` [s]; advances the integral.

        Args:
            q: (nq,); v: (nv,) measured; reference: nu_ref (6,) body FLU [m/s, rad/s].
            reference_rate: nu_ref' (6,) (None: 0); arm_acceleration: (n_arm,) the arm's commanded
                acceleration (None: 0), used with ``arm_feedforward``.
        """
        error = reference - base_twist(self.model, v)
        rate = np.zeros(6) if reference_rate is None else reference_rate
        arm = np.zeros(self.model.n_arm) if arm_acceleration is None else arm_acceleration
        feedforward = self.feedforward(q, v, rate, arm)
        wrench = feedforward + self.kp * error + self.ki * self.integral
        allocation = self.allocator.allocate(wrench)
        self._integrate(error, allocation, dt)
        return VehicleControl(wrench, feedforward, allocation, error)

    def _integrate(self, error: np.ndarray, allocation: AllocationResult, dt: float) -> None:
        """integral += dt e, except on the axes where the wrench fell short in the direction e pushes."""
        if allocation.attainable:
            self.integral += dt * error
            return
        scale = max(1.0, float(np.max(np.abs(allocation.achieved_wrench))))
        winding = (allocation.residual * error > 0) & (np.abs(allocation.residual) > 1e-6 * scale)
        self.integral += dt * np.where(winding, 0.0, error)


class VehiclePoseController:
    """Pose control on top of the velocity loop: nu_ref = K_pose [R^T (p_d - p); log3(R^T R_d)].

    Args:
        velocity: the velocity controller; gains: (6,) or a number [1/s].
        max_speed: (6,) or a number [m/s, rad/s] bound on |nu_ref| per axis (None: none).
    """

    def __init__(self, velocity: VehicleVelocityController, gains: float | np.ndarray,
                 max_speed: float | np.ndarray | None = None) -> None:
        self.velocity = velocity
        self.gains = gain_vector(gains, "pose gains")
        self.max_speed = None if max_speed is None else gain_vector(max_speed, "max_speed")

    def reference(self, pose: pin.SE3, target: pin.SE3) -> np.ndarray:
        """nu_ref (6,) [m/s, rad/s] towards ``target`` (bounded by ``max_speed``)."""
        reference = pose_velocity_reference(pose, target, self.gains)
        return reference if self.max_speed is None else np.clip(reference, -self.max_speed, self.max_speed)
