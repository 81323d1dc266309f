"""Vehicle control: a body-velocity PI controller with Fossen model feedforward, and a pose controller on top.

Velocity loop (body FLU at the vehicle's base frame, nu = [v; w] [m/s, rad/s])::

    tau = tau_model + Kp (nu_ref - nu) + Ki integral(nu_ref - nu) - d_hat
    tau_model = vehicle rows of Mbar [nu_ref'; a_m] + nbar(q, v)   (the plant's own model)

tau_model is :func:`uvms.dynamics.plant.actuated.vehicle_inverse_dynamics` of a *model* plant (the controller's
knowledge: rigid-body + added-mass inertia, Coriolis, damping, restoring; usually no current, which the
integral learns). With ``arm_feedforward`` the arm's measured velocity and commanded acceleration go in too,
so the arm's reaction wrench is compensated before it moves the vehicle; without it, the model sees the arm
at rest. tau goes through the thrust allocation; the integral is frozen on the axes where the allocation
could not give the wrench and the error would push further into the limits (conditional integration,
anti-windup).

Disturbance observer (``disturbance_time_constant`` T > 0): d_hat estimates the wrench the model does not know (an
unmodelled current's drag, which grows with the vehicle's speed through the water, a wrong added mass, a cable)
from the last step's mismatch: the wrench the model needs for the measured accelerations (finite differences of
the measured v over the step, at its mean velocity) less the wrench the actuators gave (their measured thrusts,
the step's mean), low-passed over T (:meth:`VehicleVelocityController.observe`). The integral alone learns a
constant disturbance in about 1 / (zeta omega) but trails one that changes as the vehicle speeds up; the
observer follows it within T and leaves the integral the rest (it tends back to zero). The MPC's wrench estimate
(:mod:`uvms.control.mpc.controller`) is the same idea on its prediction model.

Pose loop: pose error -> body velocity reference, world-to-body rotation written out::

    nu_ref = K_pose [R^T (p_d - p); log3(R^T R_d)],   R = world_R_body

Gains that fit the vehicle (:func:`velocity_gains`). The feedforward cancels what the model knows (Coriolis,
damping D(nu) nu at the measured nu, restoring, the arm's reaction), so per axis i the velocity error
e = nu_ref - nu obeys M_ii e' = -kp_i e - ki_i integral(e) + d_i, d the model's gaps (current, couplings, thruster
lag). With z = integral(e): M_ii z'' + kp_i z' + ki_i z = d_i, a second-order loop whose natural frequency
omega_i [rad/s] and damping ratio zeta_i are met by

    kp_i = 2 zeta_i omega_i M_ii,   ki_i = omega_i^2 M_ii

M_ii the diagonal of the vehicle block of the UVMS's rigid-body + added-mass inertia Mbar at the station, in the
base frame (:func:`vehicle_inertia`); the damping D_ii does not enter (the feedforward removes it). A constant d
leaves no velocity error (the integral). The defaults :data:`DEFAULT_BANDWIDTH` and :data:`DEFAULT_DAMPING_RATIO`
are the BlueROV2 + Alpha 5's hand-tuned gains (kp = 100 N s/m, 10 N m s/rad; ki = 150 N/m, 15 N m/rad) read as
omega and zeta: they give it kp, ki within 5 % of those in surge and sway, 11 % in roll and pitch, +15 % and +28 %
in yaw and +60 % in heave (its larger added mass), and a 1.9 t vehicle gains 100 times larger.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..dynamics.plant.actuated import base_twist, lag_factor, vehicle_inverse_dynamics, water_in_base
from ..dynamics.plant.plant import Plant
from ..dynamics.thrusters.allocation import AllocationResult, ThrustAllocator
from ..dynamics.thrusters.fin_allocation import FinAllocator
from ..errors import SolverInputError
from ..numerics._kernels import Kernel
from .settings import DEFAULT_BANDWIDTH, DEFAULT_DAMPING_RATIO, ActuatedSettings, gain_vector


def vehicle_inertia(model: Plant, q: np.ndarray) -> np.ndarray:
    """M_ii (6,) [kg, kg m^2]: the diagonal of the vehicle block of Mbar (rigid body + added mass, the arm at q
    included) in the base frame's axes (FLU at its origin).

    Args:
        model: the controller's model (its ``added_mass`` choice applies); q: (nq,) the station.
    """
    mass = model.mass_matrix(q)[:6, :6]  # vehicle joint axes
    to_joint = model.robot.base_placement.toActionMatrix()  # base-frame twist -> vehicle-joint twist
    return np.diag(to_joint.T @ mass @ to_joint).copy()


def velocity_gains(inertia: np.ndarray, bandwidth: float | np.ndarray = DEFAULT_BANDWIDTH,
                   damping_ratio: float | np.ndarray = DEFAULT_DAMPING_RATIO) -> tuple[np.ndarray, np.ndarray]:
    """(kp, ki) (6,) of the velocity loop that give each axis the natural frequency and damping ratio asked.

    kp = 2 zeta omega M [N s/m, N m s/rad], ki = omega^2 M [N/m, N m/rad] (derivation in the module docstring).

    Args:
        inertia: M_ii (6,) [kg, kg m^2] (:func:`vehicle_inertia`).
        bandwidth: omega (6,) or a number [rad/s] > 0; damping_ratio: zeta (6,) or a number > 0.

    Raises:
        SolverInputError: a bandwidth or damping ratio not > 0, or of the wrong size.
    """
    omega = gain_vector(bandwidth, "bandwidth", positive=True)
    zeta = gain_vector(damping_ratio, "damping_ratio", positive=True)
    inertia = gain_vector(inertia, "the vehicle's inertia M_ii", positive=True)
    return 2.0 * zeta * omega * inertia, omega**2 * inertia


def pose_velocity_reference(pose: pin.SE3, target: pin.SE3, gains: float | np.ndarray,
                            max_speed: float | np.ndarray | None = None) -> np.ndarray:
    """Body velocity reference nu_ref (6,) [m/s, rad/s] that moves the base frame ``pose`` to ``target``.

    Args:
        pose: world_M_body now; target: world_M_body wanted; gains: (6,) or a number [1/s], diagonal K_pose;
        max_speed: (6,) or a number [m/s, rad/s] bound on ``|nu_ref|`` per axis (None: none).

    Returns:
        K_pose [R^T (p_d - p); log3(R^T R_d)]: the position error rotated from world to body axes, the attitude
        error as a body rotation vector, clipped to +-max_speed (a new array). One compiled call
        (:func:`uvms.numerics._kernels.vehicle.pose_reference_into`) with the numbers of numpy's
        ``gains * np.concatenate([R.T @ (p_d - p), pin.log3(R.T @ R_d)])`` and
        ``np.minimum(np.maximum(nu, -max_speed), max_speed)``.
    """
    return _pose_reference_of(pose, target, _six(gains), None if max_speed is None else _six(max_speed))


def _pose_reference_of(pose: pin.SE3, target: pin.SE3, gains: np.ndarray, max_speed: np.ndarray | None) -> np.ndarray:
    """:func:`pose_velocity_reference` of gains and max_speed (None: none) given as (6,) float arrays."""
    kernel = _POSE_REFERENCE.function or _POSE_REFERENCE.load()
    reference = np.empty(6)
    kernel(pose.rotation, pose.translation, target.rotation, target.translation, gains,
           gains if max_speed is None else max_speed, max_speed is not None, reference)
    return reference


def _six(value: float | np.ndarray) -> np.ndarray:
    """value as 6 floats (a number broadcast; the controller's own (6,) arrays as they are)."""
    if value.__class__ is np.ndarray and value.shape == (6,) and value.dtype == float:
        return value
    return np.ascontiguousarray(np.broadcast_to(np.asarray(value, dtype=float), (6,)))


#: The compiled pose reference (:func:`uvms.numerics._kernels.vehicle.pose_reference_into`, numba loaded at the
#: first call).
_POSE_REFERENCE = Kernel("vehicle", "pose_reference_into")


class LagFactor:
    """:func:`~uvms.dynamics.plant.actuated.lag_factor` of the last (dt, tau) asked, computed again only when one of
    them changed: a controller asks it at every step with the same pair (the servos' lag, the observer's filter)."""

    __slots__ = ("_key", "_value")

    def __init__(self) -> None:
        self._key: tuple[float, float] | None = None
        self._value = np.float64(0.0)

    def __call__(self, dt: float, time_constant: float) -> np.float64:
        """1 - exp(-dt / tau) of dt and tau [s] (numpy's expm1, a numpy float)."""
        key = (dt, time_constant)
        if self._key != key:
            self._key, self._value = key, lag_factor(dt, time_constant)
        return self._value


@dataclass(slots=True)
class VehicleControl:
    """One output of the vehicle controller (built at every step: plain attribute writes; read it, it is never
    changed after it is built).

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
        allocator: the thrust allocation (a FinAllocator: thrusters and fins, linearized at the measured velocity
            through the water the model knows).
        settings: its part of the chain's settings (:class:`~uvms.control.settings.ActuatedSettings`): ``kp``,
            ``ki`` (used as given; None: derived at the station, :meth:`reset`, from ``bandwidth`` and
            ``damping_ratio``), ``arm_feedforward``, ``disturbance_time_constant`` (module docstring).

    Raises:
        SolverInputError: bad gains, bandwidth, damping ratio or time constant; an allocator with another number of
            rows.
    """

    def __init__(self, model: Plant, allocator: ThrustAllocator | FinAllocator,
                 settings: ActuatedSettings = ActuatedSettings()) -> None:
        if model.nb != 6:
            raise SolverInputError(f"vehicle control needs a floating base (6 body velocities), "
                                   f"{model.robot.name} has {model.nb}")
        self.model, self.allocator = model, allocator
        self.bandwidth = gain_vector(settings.bandwidth, "bandwidth", positive=True)
        self.damping_ratio = gain_vector(settings.damping_ratio, "damping_ratio", positive=True)
        #: the gains given [N s/m, N m s/rad], [N/m, N m/rad] (None: derived at the station)
        self.given = tuple(None if value is None else gain_vector(value, name)
                           for name, value in (("kp", settings.kp), ("ki", settings.ki)))
        self.kp, self.ki = self.given
        self.arm_feedforward = bool(settings.arm_feedforward)
        self.disturbance_time_constant = float(gain_vector(settings.disturbance_time_constant,
                                                           "disturbance_time_constant [s]", 1)[0])
        # the loops' vector arithmetic, compiled (numpy's numbers; numba: loaded with the controller)
        from ..numerics._kernels import vehicle as kernels
        from ..numerics._kernels.plant_stage import numpy_product_into

        self._observer_inputs, self._disturbance_update = kernels.observer_inputs_into, kernels.disturbance_update_into
        self._product = numpy_product_into  # B f as numpy's @ gives it (BLAS's gemv), without numpy's call
        self._velocity_law, self._vehicle_wrench = kernels.velocity_law_into, kernels.vehicle_wrench_into
        placement = model.base_placement  # joint_M_base, read by the compiled law as arrays
        self._placement = (placement.rotation.copy(), placement.translation.copy())
        self._gain = LagFactor()  # the observer's gain of (dt, T)
        # buffers read within one call only (what a record keeps is a new array at every step)
        nv = model.model.nv
        self._acceleration, self._mean = np.empty(nv), np.empty(nv)  # the observer's inputs
        self._needed, self._nu = np.empty(6), np.empty(6)  # the model's wrench for them; nu of the last control
        self._terms = np.empty((nv, nv)), np.empty(nv)  # Mbar, nbar at the feedforward's velocity (:meth:`observe`)
        self._rest = np.zeros(6)  # nu_ref' when none is given (read only)
        self.reset()

    def reset(self, station: np.ndarray | None = None) -> None:
        """Zero the integral and the disturbance estimate, forget the last measurement; at ``station`` (nq,), where
        a run starts, the gains not given are derived from the vehicle's inertia M_ii there
        (:func:`velocity_gains`)."""
        if station is not None and any(value is None for value in self.given):
            derived = velocity_gains(vehicle_inertia(self.model, station), self.bandwidth, self.damping_ratio)
            self.kp, self.ki = (derived[index] if value is None else value for index, value in enumerate(self.given))
        self.integral = np.zeros(6)  # integral of the velocity error [m, rad]
        self.disturbance = np.zeros(6)  # d_hat [N, N m] body FLU
        self._last: tuple[np.ndarray, np.ndarray] | None = None  # (v (nv,), applied wrench (6,)) of the last call
        self._short = np.zeros(6)  # the last allocation's residual where it fell short (asked - achieved) [N, N m]
        self._falls_short = False  # any entry of _short is not zero

    def observe(self, q: np.ndarray, v: np.ndarray, applied: np.ndarray,
                dt: float) -> tuple[np.ndarray, np.ndarray] | None:
        """Update d_hat (6,) [N, N m] (:attr:`disturbance`) from the step since the last call; return the model's
        terms at the measured state for :meth:`control` (``terms``): Mbar (nv, nv) at q and nbar (nv,) at the
        feedforward's velocity, evaluated with the observer's (M and the Jacobians once), this object's buffers until
        the next call; None when nothing was evaluated (the first call, no observer).

        d = tau_needed - (applied_last + applied) / 2 with tau_needed the model's wrench
        (:func:`~uvms.dynamics.plant.actuated.vehicle_inverse_dynamics`, the arm's measured motion included) for the
        measured acceleration (v - v_last) / dt at the step's mean velocity; d_hat += (1 - exp(-dt / T)) (d - d_hat),
        except on the axes where the last allocation fell short by r = asked - achieved in the direction the change
        would push the wrench: there d_hat += (1 - exp(-dt / T)) r (back-calculation), so the wrench asked comes
        back to what the thrusters give instead of going beyond it (a saturated surge asked ever more would take,
        in the allocation's least squares, the thrust of the other axes: the attitude).

        Args:
            q: (nq,) and v: (nv,) measured now; applied: the wrench (6,) [N, N m] the actuators give now (B f of the
                measured thrusts, the fins' at their measured angles), base frame; dt: the time since the last call
                [s].
        """
        applied, last = np.asarray(applied, dtype=float), self._last
        if applied.shape != (6,) or (last is not None and last[0].shape != v.shape):
            raise SolverInputError(f"observe needs the applied wrench as 6 numbers and v of the last call's size "
                                   f"({len(last[0]) if last else len(v)}), got {applied.shape} and {v.shape}")
        self._last = (v.copy(), applied.copy())
        if last is None or self.disturbance_time_constant <= 0.0:
            return None
        v0, applied0 = last
        acceleration, mean = self._acceleration, self._mean
        self._observer_inputs(v, v0, dt, acceleration, mean)
        needed = vehicle_inverse_dynamics(self.model, q, mean, acceleration[:6], acceleration[6:], out=self._needed,
                                          placement=self._placement, second=(self._feedforward_velocity(v),
                                                                             *self._terms))
        disturbance = np.empty(6)  # a new array at every step (a row keeps the last one)
        self._disturbance_update(needed, applied0, self._last[1], self.disturbance, self._observer_gain(dt),
                                 self._short, self._falls_short, disturbance)
        self.disturbance = disturbance
        return self._terms

    def _observer_gain(self, dt: float) -> float:
        """1 - exp(-dt / T) of the step dt [s] (the first-order filter's :class:`LagFactor`)."""
        return self._gain(dt, self.disturbance_time_constant)

    def applied_wrench(self, q: np.ndarray, v: np.ndarray, thrusts: np.ndarray,
                       fins: np.ndarray | None = None) -> np.ndarray:
        """The wrench (6,) [N, N m] base frame the actuators give at the measured thrusts (n,) [N] and fin angles (m,)
        [rad] (B f, plus the fins' lift and drag at the measured velocity through the water the model knows)."""
        allocator, wrench = self.allocator, np.empty(6)
        with_fins = isinstance(allocator, FinAllocator)
        # numpy's B @ f (BLAS's gemv) in one compiled call: numpy's own first BLAS call of a step took ~12 us (measured
        # in the run, 0.3-0.5 us alone), the compiled one ~0.9 us, and a step ~20 us less
        self._product(allocator.thrusters.matrix if with_fins else allocator.matrix,
                      np.asarray(thrusts, dtype=float), wrench)
        if with_fins and fins is not None and len(allocator.fins):
            wrench = wrench + allocator.fins.wrench(base_twist(self.model, v), water_in_base(self.model, q), fins)
        return wrench

    def feedforward(self, q: np.ndarray, v: np.ndarray, reference_rate: np.ndarray, arm_acceleration: np.ndarray,
                    terms: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
        """tau_model (6,) [N, N m]: the model's wrench for the vehicle rate ``reference_rate`` (6,), body FLU (mapped
        to the vehicle joint's axes in the compiled rows); ``terms``: what :meth:`observe` returned at this (q, v)
        (None: the model evaluated here; the same numbers)."""
        model = self.model
        if not self.arm_feedforward:
            arm_acceleration = np.zeros(model.n_arm)
        if terms is None:
            return vehicle_inverse_dynamics(model, q, self._feedforward_velocity(v), reference_rate, arm_acceleration,
                                            base_frame=True, placement=self._placement)
        wrench = np.empty(6)
        self._vehicle_wrench(*terms, reference_rate, arm_acceleration, *self._placement, True, wrench)
        return wrench

    def _feedforward_velocity(self, v: np.ndarray) -> np.ndarray:
        """The velocity (nv,) the feedforward's model is evaluated at: v, or the vehicle's alone (the arm at rest)
        without ``arm_feedforward``."""
        return v if self.arm_feedforward else np.concatenate([v[:6], np.zeros(self.model.n_arm)])

    def control(self, q: np.ndarray, v: np.ndarray, reference: np.ndarray, dt: float, *,
                reference_rate: np.ndarray | None = None, arm_acceleration: np.ndarray | None = None,
                terms: tuple[np.ndarray, np.ndarray] | None = None) -> VehicleControl:
        """The wrench and thrusts for one control period ``dt`` [s]; advances the integral. The disturbance
        estimate d_hat is the last :meth:`observe`'s (zero without the observer).

        Args:
            q: (nq,); v: (nv,) measured; reference: nu_ref (6,) body FLU [m/s, rad/s].
            reference_rate: nu_ref' (6,) (None: 0); arm_acceleration: (n_arm,) the arm's commanded
                acceleration (None: 0), used with ``arm_feedforward``; terms: :meth:`observe`'s at this (q, v)
                (None: the model evaluated here).
        """
        reference = np.asarray(reference, dtype=float)
        if reference.shape != (6,) or v.shape[0] < 6 or self.kp is None or self.ki is None:
            raise SolverInputError(f"control needs nu_ref as 6 numbers [m/s, rad/s] (got {reference!r}), v of the "
                                   f"UVMS (got {v.shape}) and the gains (derived at the station by reset(q0) when "
                                   f"not given)")
        rate = self._rest if reference_rate is None else reference_rate
        arm = np.zeros(self.model.n_arm) if arm_acceleration is None else arm_acceleration
        feedforward = self.feedforward(q, v, rate, arm, terms)
        # nu (base_twist's numbers), the velocity error, the wrench and the integral after the step in one compiled
        # call; what the step returns and a row keeps is new (nu is read by the allocation alone)
        nu, error, wrench, integral = self._nu, np.empty(6), np.empty(6), np.empty(6)
        self._velocity_law(reference, v, *self._placement, feedforward, self.kp, self.ki, self.integral,
                           self.disturbance, dt, nu, error, wrench, integral)
        # the water's velocity moves the fins' lift alone: a thrusters-only allocation does not read it
        current = water_in_base(self.model, q) if isinstance(self.allocator, FinAllocator) else None
        allocation = self.allocator.allocate(wrench, nu, current)
        self._integrate(error, allocation, dt, integral)
        return VehicleControl(wrench, feedforward, allocation, error)

    def _integrate(self, error: np.ndarray, allocation: AllocationResult, dt: float, integral: np.ndarray) -> None:
        """integral += dt e (``integral``: the law's integral + dt e), except on the axes where the wrench fell short
        in the direction e pushes. The integral is a new array at every step (a row that holds the last one keeps its
        numbers)."""
        if allocation.attainable:
            if self._falls_short:
                self._short, self._falls_short = np.zeros(6), False
            self.integral = integral
            return
        scale = max(1.0, float(np.max(np.abs(allocation.achieved_wrench))))
        self._short = np.where(np.abs(allocation.residual) > 1e-6 * scale, allocation.residual, 0.0)
        self._falls_short = bool(self._short.any())
        self.integral = self.integral + dt * np.where(self._short * error > 0, 0.0, error)


class VehiclePoseController:
    """Pose control on top of the velocity loop: nu_ref = K_pose [R^T (p_d - p); log3(R^T R_d)].

    Args:
        velocity: the velocity controller; gains: (6,) or a number [1/s].
        max_speed: (6,) or a number [m/s, rad/s] bound on ``|nu_ref|`` per axis (None: none).
    """

    def __init__(self, velocity: VehicleVelocityController, gains: float | np.ndarray,
                 max_speed: float | np.ndarray | None = None) -> None:
        self.velocity = velocity
        self.gains = gain_vector(gains, "pose gains")
        self.max_speed = None if max_speed is None else gain_vector(max_speed, "max_speed")

    def reference(self, pose: pin.SE3, target: pin.SE3) -> np.ndarray:
        """nu_ref (6,) [m/s, rad/s] towards ``target``, bounded by ``max_speed`` (:func:`pose_velocity_reference`)."""
        return _pose_reference_of(pose, target, self.gains, self.max_speed)  # its gains checked as 6 floats
