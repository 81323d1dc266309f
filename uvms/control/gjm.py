"""Inverse kinematic control of a free-floating UVMS with the generalized Jacobian (amundsen2018, sec. II-III).

The vehicle is passive: only the joints are commanded, and the end effector is
controlled in inertial (world) axes through the generalized Jacobian matrix
(GJM), which accounts for the vehicle's reaction. With the task rows ``rows``
(e.g. the 3 linear ones, the sub-matrix of sec. III) and the end-effector
reference p_d(t), v_d(t)::

    nu_c = [v_d + K (p_d - p); omega_d]                  (eq. 8, position feedback only)
    w    = GJM_r^T (GJM_r GJM_r^T + lambda^2 I)^-1 nu_c  (eq. 4-5, DLS)
    lambda^2 = (1 - (sigma_min / eps)^2) lambda_max^2 when sigma_min < eps, else 0   (eq. 6)

K = 0 is the paper's open loop (the joints integrate the commanded velocities;
the end-effector position is only measured, never fed back); K = 3 I its closed
loop (CLIK, eq. 7). The GJM is evaluated at the measured joint angles and
vehicle orientation (encoders and IMU), as in the paper.

Which GJM (``gjm``):

* ``"rigid"`` — the classic one, from the rigid-body momentum (``Robot.generalized_jacobian``);
* ``"added_mass"`` — from the momentum of the links *and the water they carry*
  (link inertias augmented with their added mass, :func:`uvms.plant.generalized_jacobian_added_mass`):
  exact in an inviscid fluid at rest, where that augmented momentum is conserved;
* ``"fixed_base"`` — the arm columns J_m of the ordinary Jacobian, as if the vehicle
  were held still (the traditional scheme the paper contrasts with; for comparisons).

Joint servos. The plant's joints follow their commanded velocity through a
first-order servo of time constant tau (amundsen2018: 100 ms). Sent as is, w is
tracked with a lag, which alone moves the end effector off its reference; with
``motor_feedforward = tau`` the controller sends u = w + tau dw/dt, the inverse of
the servo, so that the joint rates equal w whenever they did at the start.
dw/dt is taken along the measured motion: dw/dt = (d GJM^#/dt) nu_c + GJM^# d nu_c/dt,
the first term by a forward difference along q' = v, the second from the
reference acceleration.
"""

from __future__ import annotations

import bisect
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..errors import GJMControlError, UVMSError
from ..dynamics.hydrodynamics import HydroParameters, hydrodynamics_of
from ..kinematics import AXIS_NAMES, axis_rows
from ..dynamics.plant import augmented_mass_matrix, resolve_links
from ..robot import Robot
from ..solvers.clik import VariableDamping, damped_weighted_inverse
from ..solvers.inverses import weights_factor
from ..trajectory.cartesian import PoseSample

#: The generalized Jacobians the controller can invert.
GJM_KINDS = ("rigid", "added_mass", "fixed_base")


# ------------------------------------------------------------------ reference
class VelocityRamps:
    """End-effector reference from velocity ramps: v(t) piecewise linear, p(t) its exact integral.

    v(t) is linear between the knots (times[k], velocities[k]) and constant
    outside them; p(t) = start + integral of v from times[0]. The orientation of
    the desired pose is constant (``rotation``) and the desired angular velocity
    zero: this is the reference of amundsen2018 sec. III (eq. 9-11), whose
    positions are "the integrals of the velocity references".

    The acceleration at an interior knot (and at the last one) is the mean of the
    slopes on both sides, at the first knot the slope after it. A fixed-step
    integrator that lands on a ramp corner then errs by +- half the jump on the
    two sides of it, which cancel (a one-sided value would leave an error of order dt).

    Args:
        start: p(times[0]) (3,) [m], world frame.
        times: knot times (K,) [s], strictly increasing, K >= 2.
        velocities: (K, 3) [m/s] at the knots, world axes.
        rotation: constant orientation of the desired pose (3, 3) (default identity).

    Raises:
        GJMControlError: wrong shapes, non-finite values, times not increasing.
    """

    def __init__(self, start: Sequence[float], times: Sequence[float], velocities: Sequence[Sequence[float]],
                 rotation: np.ndarray | None = None) -> None:
        self.start = _finite(start, (3,), "start")
        self.times = _finite(times, (None,), "times")
        self.velocities = _finite(velocities, (len(self.times), 3), "velocities")
        if len(self.times) < 2 or np.any(np.diff(self.times) <= 0):
            raise GJMControlError(f"times must be at least 2 strictly increasing knot times [s], got {self.times.tolist()}")
        self.rotation = np.eye(3) if rotation is None else _finite(rotation, (3, 3), "rotation")
        self._knots = self.times.tolist()
        spans = np.diff(self.times)
        self.slopes = np.diff(self.velocities, axis=0) / spans[:, None]  # (K-1, 3) [m/s^2]
        areas = 0.5 * (self.velocities[1:] + self.velocities[:-1]) * spans[:, None]
        self.knot_positions = self.start + np.vstack([np.zeros(3), np.cumsum(areas, axis=0)])  # (K, 3)

    @classmethod
    def trapezoid(cls, start: Sequence[float], velocity: Sequence[float], duration: float, ramp_time: float,
                  rotation: np.ndarray | None = None) -> VelocityRamps:
        """Ramp from rest to ``velocity`` in ``ramp_time``, cruise, ramp back to rest at ``duration``.

        Args:
            start: (3,) [m]; velocity: cruise velocity (3,) [m/s], world axes.
            duration: total time [s] > 0; ramp_time: (0, duration / 2] [s].
        """
        duration, ramp_time = float(duration), float(ramp_time)
        if not (np.isfinite(duration) and duration > 0):
            raise GJMControlError(f"duration must be finite and > 0 s, got {duration!r}")
        if not (np.isfinite(ramp_time) and 0 < ramp_time <= duration / 2):
            raise GJMControlError(f"ramp_time must be in (0, duration/2] = (0, {duration / 2:g}] s, got {ramp_time!r}")
        cruise = _finite(velocity, (3,), "velocity")
        if ramp_time == duration / 2:
            return cls(start, [0.0, ramp_time, duration], [np.zeros(3), cruise, np.zeros(3)], rotation)
        return cls(start, [0.0, ramp_time, duration - ramp_time, duration],
                   [np.zeros(3), cruise, cruise, np.zeros(3)], rotation)

    @property
    def duration(self) -> float:
        """Time of the last knot [s]."""
        return float(self.times[-1])

    def _segment(self, t: float) -> int:
        """Index k of the segment [times[k], times[k+1]) that holds t (clipped to the first and last)."""
        return min(max(bisect.bisect_right(self._knots, t) - 1, 0), len(self._knots) - 2)

    def velocity(self, t: float) -> np.ndarray:
        """v_d(t) (3,) [m/s]."""
        if t <= self.times[0]:
            return self.velocities[0].copy()
        if t >= self.times[-1]:
            return self.velocities[-1].copy()
        k = self._segment(t)
        return self.velocities[k] + self.slopes[k] * (t - self.times[k])

    def position(self, t: float) -> np.ndarray:
        """p_d(t) (3,) [m]."""
        if t <= self.times[0]:
            return self.start + self.velocities[0] * (t - self.times[0])
        if t >= self.times[-1]:
            return self.knot_positions[-1] + self.velocities[-1] * (t - self.times[-1])
        k = self._segment(t)
        s = t - self.times[k]
        return self.knot_positions[k] + self.velocities[k] * s + 0.5 * self.slopes[k] * s * s

    def acceleration(self, t: float) -> np.ndarray:
        """dv_d/dt (3,) [m/s^2]; at a knot the mean of both sides (the right side at the first knot)."""
        knots, slopes = self._knots, self.slopes
        tolerance = 1e-12 * max(1.0, abs(t))
        if t < knots[0] - tolerance or t > knots[-1] + tolerance:
            return np.zeros(3)
        k = bisect.bisect_left(knots, t)  # knots[k - 1] < t <= knots[k]
        if k > 0 and (k == len(knots) or t - knots[k - 1] < knots[k] - t):
            k -= 1  # the nearer knot
        if abs(knots[k] - t) <= tolerance:  # on a knot (up to rounding of the stage times)
            if k == 0:
                return slopes[0].copy()
            after = slopes[k] if k < len(slopes) else np.zeros(3)
            return 0.5 * (slopes[k - 1] + after)
        return slopes[self._segment(t)].copy()

    def __call__(self, t: float) -> PoseSample:
        """Desired pose, twist [v; 0] (6,) and acceleration [a; 0] (6,) at t [s], world axes."""
        zeros = np.zeros(3)
        return PoseSample(pin.SE3(self.rotation, self.position(t)),
                          np.concatenate([self.velocity(t), zeros]), np.concatenate([self.acceleration(t), zeros]))


def _finite(values, shape: tuple, what: str) -> np.ndarray:
    try:
        array = np.array(values, dtype=float)
    except (TypeError, ValueError):
        raise GJMControlError(f"{what} must be numbers, got {values!r}") from None
    if array.ndim != len(shape) or any(size is not None and size != actual for size, actual in zip(shape, array.shape)):
        expected = "x".join("K" if size is None else str(size) for size in shape)
        raise GJMControlError(f"{what} must have shape ({expected}), got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise GJMControlError(f"{what} must be finite, got {array.tolist()}")
    return array


# ------------------------------------------------------------------ controller
@dataclass(frozen=True)
class GJMSample:
    """What the controller computes at one (q, t).

    Attributes:
        rates: w (n_arm,) joint velocities [rad/s] (before the servo feedforward).
        command: nu_c (k,) the task velocity inverted (eq. 8) [m/s, rad/s].
        position_error: p_d - p (3,) [m] world (zeros when the task has no position row).
        sigma_min: smallest singular value of the task rows of the GJM.
        damping: lambda used (eq. 6).
    """

    rates: np.ndarray
    command: np.ndarray
    position_error: np.ndarray
    sigma_min: float
    damping: float


class GJMController:
    """Joint-velocity commands that move a frame along a reference with the vehicle passive.

    Args:
        robot: a floating- or planar-base Robot.
        reference: t -> PoseSample (pose, twist (6,), acceleration (6,)), e.g.
            :class:`VelocityRamps` or a ``uvms.trajectory`` pose trajectory.
        frame: controlled frame (default: the first end effector).
        axes: task axes, any of x y z roll pitch yaw (default x, y, z: 3-DOF linear control,
            the sub-matrix of amundsen2018 sec. III). Position axes get feedback, angular
            ones only the reference's angular velocity (eq. 8).
        gain: K [1/s]: scalar, (3,) diagonal or (3, 3), on the position error; 0 = open loop.
        damping: fixed lambda >= 0 or a :class:`uvms.VariableDamping` (eq. 6).
        weights: joint weights W (n_arm,) or (n_arm, n_arm) (weighted DLS); None: W = I as in the paper.
        gjm: "rigid", "added_mass" or "fixed_base" (see the module docstring).
        hydro: parameters of the added-mass GJM (None: the model's own).
        motor_feedforward: tau [s] of the joint servos to invert (u = w + tau dw/dt); 0: send w.
        difference_step: time step [s] of the forward difference of dGJM^#/dt.

    Raises:
        GJMControlError: a fixed base, unknown axes or GJM kind, bad gain or tau.
        SolverInputError: weights not (n_arm,) positive nor (n_arm, n_arm) symmetric positive definite.
        UVMSError: the model has no hydrodynamic parameters and ``gjm = "added_mass"``.
    """

    def __init__(
        self,
        robot: Robot,
        reference,
        *,
        frame: str | None = None,
        axes: Sequence[str] = ("x", "y", "z"),
        gain: float | np.ndarray = 0.0,
        damping: float | VariableDamping = 0.0,
        weights: np.ndarray | None = None,
        gjm: str = "rigid",
        hydro: HydroParameters | None = None,
        motor_feedforward: float = 0.0,
        difference_step: float = 1e-6,
    ) -> None:
        if robot.base_type == "fixed":
            raise GJMControlError(f"{robot.name} has a fixed base: GJM control needs a free-floating (or planar) vehicle")
        if gjm not in GJM_KINDS:
            raise GJMControlError(f"unknown gjm {gjm!r}; valid: {', '.join(GJM_KINDS)}")
        try:
            self.rows = axis_rows(axes)
        except UVMSError as exc:
            raise GJMControlError(str(exc)) from None
        if not self.rows:
            raise GJMControlError(f"axes must name at least one of {', '.join(AXIS_NAMES)}")
        self.robot, self.reference, self.gjm = robot, reference, gjm
        self.frame = frame or robot.ee_frames[0]
        self.frame_id = robot.frame_id(self.frame)
        self.axes = tuple(axes)
        self.position_rows = [i for i, row in enumerate(self.rows) if row < 3]  # indices into the task rows
        self.gain = _gain_matrix(gain)
        self.damping = damping
        self.weights = None if weights is None else np.asarray(weights, dtype=float)
        if self.weights is not None:
            weights_factor(self.weights, robot.n_arm)  # raises SolverInputError with what is valid
        tau = float(motor_feedforward)
        if not (np.isfinite(tau) and tau >= 0):
            raise GJMControlError(f"motor_feedforward must be a time constant >= 0 s, got {motor_feedforward!r}")
        self.motor_feedforward = tau
        step = float(difference_step)
        if not (np.isfinite(step) and step > 0):
            raise GJMControlError(f"difference_step must be > 0 s, got {difference_step!r}")
        self.difference_step = step
        self.model = robot.model
        self.data = robot.model.createData()  # own workspace: callers may hold views into robot.data
        self._mass_data = robot.model.createData()
        self.nb = robot.n_vehicle
        self.links = []
        if gjm == "added_mass":
            self.hydro = hydrodynamics_of(robot) if hydro is None else hydro
            self.links = resolve_links(self.model, self.hydro)
        else:
            self.hydro = hydro

    # ------------------------------------------------------------- Jacobians
    def _kinematics(self, q: np.ndarray) -> tuple[np.ndarray, pin.SE3]:
        """World-aligned frame Jacobian (6, nv) and pose at q."""
        model, data = self.model, self.data
        jacobian = pin.computeFrameJacobian(model, data, q, self.frame_id, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        return jacobian, data.oMf[self.frame_id]

    def _generalized(self, q: np.ndarray, jacobian: np.ndarray) -> np.ndarray:
        nb = self.nb
        if self.gjm == "fixed_base":
            return jacobian[:, nb:]
        if self.gjm == "added_mass":
            mass = augmented_mass_matrix(self.model, self._mass_data, self.links, q)
            return jacobian[:, nb:] - jacobian[:, :nb] @ np.linalg.solve(mass[:nb, :nb], mass[:nb, nb:])
        return self.robot.generalized_jacobian(q, self.frame)

    def generalized_jacobian(self, q: np.ndarray) -> np.ndarray:
        """The GJM (6, n_arm) this controller inverts (all six rows, world-aligned)."""
        q = self.robot.check_configuration(q)
        return self._generalized(q, self._kinematics(q)[0])

    # ------------------------------------------------------------- control
    def _task_velocity(self, sample: PoseSample, position: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """nu_c on the task rows (k,) and the position error p_d - p (3,)."""
        error = sample.pose.translation - position
        command = sample.twist.copy()
        command[:3] += self.gain @ error
        return command[self.rows], error

    def _inverse(self, jacobian: np.ndarray) -> tuple[np.ndarray, float, float]:
        return damped_weighted_inverse(jacobian[self.rows], self.weights, self.damping)

    def sample(self, q: np.ndarray, t: float) -> GJMSample:
        """The joint rates w at (q, t) and the quantities behind them.

        Raises:
            ConfigurationError: q of the wrong size or not finite.
        """
        q = self.robot.check_configuration(q)
        return self._sample(q, t)

    def _sample(self, q: np.ndarray, t: float) -> GJMSample:
        jacobian, pose = self._kinematics(q)
        inverse, sigma_min, used = self._inverse(self._generalized(q, jacobian))
        command, error = self._task_velocity(self.reference(t), pose.translation)
        return GJMSample(inverse @ command, command, error if self.position_rows else np.zeros(3), sigma_min, used)

    def tracking(self, t: float, q: np.ndarray, v: np.ndarray) -> dict:
        """The tracking series of a run's row at (t, q, v): pose and velocity of the frame and of the reference,
        the joint rates w and the inverse's sigma_min and damping (a recorder of :func:`uvms.simulate.simulate_gjm`)."""
        jacobian, pose = self._kinematics(q)
        sample = self._sample(q, t)
        reference = self.reference(t)
        return {"ee_position": pose.translation.copy(), "desired_position": reference.pose.translation.copy(),
                "ee_velocity": jacobian[:3] @ v, "desired_velocity": reference.twist[:3].copy(), "rates": sample.rates,
                "sigma_min": sample.sigma_min, "damping": sample.damping}

    def __call__(self, t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """The joint-velocity command u (n_arm,) at (t, q, v): w, plus tau dw/dt with the servo feedforward.

        The signature of a :func:`uvms.plant.simulate_plant` command.
        """
        jacobian, pose = self._kinematics(q)
        generalized = self._generalized(q, jacobian)
        inverse, _, _ = self._inverse(generalized)
        sample = self.reference(t)
        command, _ = self._task_velocity(sample, pose.translation)
        rates = inverse @ command
        if self.motor_feedforward == 0.0:
            return rates
        h = self.difference_step
        ahead = pin.integrate(self.model, q, v * h)
        inverse_ahead, _, _ = self._inverse(self._generalized(ahead, self._kinematics(ahead)[0]))
        command_rate = sample.acceleration.copy()  # d nu_c / dt = a_d + K (v_d - p')
        command_rate[:3] += self.gain @ (sample.twist[:3] - jacobian[:3] @ v)
        rate_of_rates = (inverse_ahead - inverse) @ command / h + inverse @ command_rate[self.rows]
        return rates + self.motor_feedforward * rate_of_rates


def _gain_matrix(gain) -> np.ndarray:
    """K (3, 3) from a scalar, a diagonal (3,) or a matrix (3, 3); finite and >= 0 (positive semi-definite)."""
    array = np.asarray(gain, dtype=float)
    if array.ndim == 0:
        array = float(array) * np.eye(3)
    elif array.shape == (3,):
        array = np.diag(array)
    if array.shape != (3, 3) or not np.all(np.isfinite(array)):
        raise GJMControlError(f"gain K must be a number, 3 numbers or a 3x3 matrix [1/s], got {gain!r}")
    if np.min(np.linalg.eigvalsh(0.5 * (array + array.T))) < 0:
        raise GJMControlError(f"gain K must be positive semi-definite (0 = open loop), got {gain!r}")
    return array


def __getattr__(name: str):
    """``simulate_gjm`` and ``GJMResult`` moved to :mod:`uvms.simulate` (the one loop and result); this old path
    keeps working for one release."""
    if name in ("simulate_gjm", "GJMResult"):
        from ..simulate import GJMResult, simulate_gjm  # lazily: the loop sits above this layer

        return {"GJMResult": GJMResult, "simulate_gjm": simulate_gjm}[name]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
