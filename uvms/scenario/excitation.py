"""Excitation for hydrodynamic identification: a multi-sine body wrench through the thrusters, arm held or moving.

:func:`excitation_run` simulates the model's actuated plant (:class:`uvms.dynamics.plant.actuated.ActuatedPlant`, the
one loop :func:`uvms.sim.loop.simulate`) under open-loop thrust commands f = sat(B^+ tau(t)), tau(t) a
:class:`Multisine` body wrench, and the arm under a sum of sines of joint velocity; :func:`log_of_run` turns the
run into the log identification reads (:class:`uvms.dynamics.identification.data.IdentificationLog`), the same
numbers ``write_bag`` writes (``/odom``, ``/joint_states``, ``/body_wrench``). Plan an experiment with it (are the
thrusters within their limits, which axes move), and the tests get logs of known parameters.

The multi-sine: per axis i, sum_k a_i sqrt(2/n) sin(2 pi f_ik t + phi_k), RMS a_i over its period 1 / f_0; the
frequencies of the six axes interleave on the grid f_0, 2 f_0, ..., 6 n f_0 = ``highest`` (axis i takes every sixth
line from the i-th), so no two axes share a frequency and their effects separate; Schroeder's phases
phi_k = -pi k (k - 1) / n keep the peaks low.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..dynamics.hydro.parameters import HydroParameters
from ..dynamics.identification.data import IdentificationLog
from ..dynamics.plant.actuated import ActuatedPlant
from ..dynamics.plant.command import Command, State
from ..dynamics.plant.plant import Plant
from ..errors import IdentificationError
from ..robot.robot import Robot
from ..sim.loop import simulate
from ..sim.result import SimulationResult
from .bags.tf_tree import vehicle_root_link


@dataclass(frozen=True)
class Multisine:
    """A multi-sine body wrench (module docstring): amplitudes (6,) RMS [N, N m], frequencies and phases (6, n)."""

    amplitudes: np.ndarray
    frequencies: np.ndarray
    phases: np.ndarray

    def __call__(self, t: float) -> np.ndarray:
        """tau(t) (6,) [N, N m], body FLU at the vehicle's base frame."""
        count = self.frequencies.shape[1]
        waves = np.sin(2.0 * np.pi * self.frequencies * t + self.phases)
        return self.amplitudes * np.sqrt(2.0 / count) * np.sum(waves, axis=1)


def multisine(amplitudes: np.ndarray, *, highest: float = 0.5, components: int = 8, seed: int = 0) -> Multisine:
    """A multi-sine of RMS ``amplitudes`` (6,) [N, N m] (0: the axis is not excited), ``components`` sines per axis
    up to ``highest`` [Hz] (module docstring; the default's period is 96 s, its lowest line 0.0104 Hz), with
    Schroeder's phases (``seed`` 0) or phases drawn uniformly in [0, 2 pi) from ``seed`` (another realization).

    Raises:
        IdentificationError: amplitudes not 6 numbers >= 0, highest <= 0, components < 1.
    """
    amplitudes = np.asarray(amplitudes, dtype=float)
    if amplitudes.shape != (6,) or not np.all(np.isfinite(amplitudes)) or np.any(amplitudes < 0):
        raise IdentificationError(f"the excitation needs 6 amplitudes >= 0 [N, N m], got {amplitudes.tolist()}")
    if not (np.isfinite(highest) and highest > 0.0):
        raise IdentificationError(f"the excitation's highest frequency must be > 0 Hz, got {highest!r}")
    if components < 1:
        raise IdentificationError(f"the excitation needs at least 1 sine per axis, got {components}")
    grid = highest / (6 * components) * np.arange(1, 6 * components + 1)
    frequencies = np.array([grid[axis::6] for axis in range(6)])
    k = np.arange(1, components + 1)
    phases = (np.tile(-np.pi * k * (k - 1) / components, (6, 1)) if seed == 0
              else np.random.default_rng(seed).uniform(0.0, 2.0 * np.pi, (6, components)))
    return Multisine(amplitudes, frequencies, phases)


def arm_motion(amplitudes: np.ndarray, period: float = 20.0):
    """Joint-velocity commands (t -> (n,) [rad/s or m/s]) moving joint j by amplitudes[j] sin(2 pi t / T_j)
    about where it starts, T_j = period / (1 + 0.37 j) (incommensurate), amplitudes [rad or m]."""
    amplitudes = np.asarray(amplitudes, dtype=float)
    omega = 2.0 * np.pi * (1.0 + 0.37 * np.arange(len(amplitudes))) / period
    return lambda t: amplitudes * omega * np.cos(omega * t)


def excitation_run(robot: Robot, wrench: Multisine, q0: np.ndarray, duration: float, dt: float, *,
                   hydro: HydroParameters | None = None, arm_amplitudes: np.ndarray | None = None,
                   current: np.ndarray | None = None) -> tuple[SimulationResult, ActuatedPlant]:
    """Simulate the model under the multi-sine (open loop), gravity on (weight and buoyancy).

    Args:
        robot: a floating-base model with thrusters (its ``thrusters.yaml`` or plugins); hydro: its
            hydrodynamics (None: the model's); q0: (nq,) the start; duration, dt: [s] (dt is the log's step).
        arm_amplitudes: (n_arm,) joint motion amplitudes [rad or m] (None: the arm held, zero command).
        current: (3,) [m/s] world ENU (None: the hydrodynamics' own).

    Returns:
        The run (with ``actuation.body_wrench``) and the actuated plant (its thrust bounds, to check saturation).
    """
    plant = Plant(robot, hydro, gravity=True, current=current)
    actuated = ActuatedPlant.of(plant, fins=False)
    controller = ExcitationControl(actuated, wrench, arm_amplitudes)
    return simulate(actuated, controller, q0, duration, dt, progress=False), actuated


class ExcitationControl:
    """The open-loop commands of an excitation: thrusts sat(B^+ tau(t)), the arm's sum of sines (or held).

    Args:
        actuated: the plant with its thrusters (B (6, n), bounds); wrench: tau(t).
        arm_amplitudes: (n_arm,) [rad or m] (:func:`arm_motion`), None: the arm held; arm_period: [s].
    """

    def __init__(self, actuated: ActuatedPlant, wrench: Multisine, arm_amplitudes: np.ndarray | None = None,
                 arm_period: float = 20.0) -> None:
        self.actuated, self.wrench = actuated, wrench
        self.allocation = np.linalg.pinv(actuated.matrix)  # (n, 6)
        n_arm = actuated.plant.n_arm
        self.arm = (lambda t: np.zeros(n_arm)) if arm_amplitudes is None else arm_motion(arm_amplitudes, arm_period)

    def thrust(self, t: float) -> np.ndarray:
        """B^+ tau(t) (n,) [N], before saturation."""
        return self.allocation @ self.wrench(t)

    def reset(self, state: State, t: float = 0.0) -> None:
        """Nothing to reset: the commands depend on time only."""

    def command(self, state: State, t: float) -> Command:
        """The arm's and the thrusters' commands at t [s] (:class:`uvms.control.base.Controller`)."""
        return Command(arm=self.arm(t), thrust=self.actuated.saturate(self.thrust(t)), info={})

    def peak_ratio(self, duration: float, dt: float) -> float:
        """The largest |thrust command| over its limit on the run's steps (> 1: the excitation saturates)."""
        times = np.arange(0.0, duration + 0.5 * dt, dt)
        thrust = np.array([self.thrust(t) for t in times])  # (N, n)
        limit = np.where(thrust >= 0.0, self.actuated.upper, -self.actuated.lower)
        return float(np.max(np.abs(thrust) / np.maximum(limit, 1e-12)))


def log_of_run(robot: Robot, result: SimulationResult, source: str = "simulated run") -> IdentificationLog:
    """The log of an actuated run: the root link's pose and body twist (Pinocchio LOCAL), the arm joints, the
    thrusters' body wrench.

    Raises:
        IdentificationError: a run without thrusters (no body wrench) or a fixed base.
    """
    root = vehicle_root_link(robot)
    if result.actuation is None or root is None:
        raise IdentificationError("identification needs a run of an actuated vehicle (thrusters: its body wrench)")
    model, data = robot.model, robot.model.createData()
    positions, quaternions, twists = [], [], []
    for q, v in zip(result.q, result.v):
        pin.forwardKinematics(model, data, q, v)
        pose = pin.updateFramePlacement(model, data, root)
        positions.append(pose.translation.copy())
        quaternions.append(pin.Quaternion(pose.rotation).coeffs().copy())
        twists.append(pin.getFrameVelocity(model, data, root, pin.ReferenceFrame.LOCAL).vector.copy())
    nb = robot.n_vehicle
    arm = np.array([robot.arm_configuration(q) for q in result.q])
    return IdentificationLog(result.t, np.array(positions), np.array(quaternions), np.array(twists),
                             np.asarray(result.actuation.body_wrench), tuple(robot.arm_joint_names), arm,
                             np.asarray(result.v)[:, nb:], source)


def with_odometry_noise(log: IdentificationLog, *, position: float = 0.0, attitude: float = 0.0,
                        linear: float = 0.0, angular: float = 0.0, seed: int = 0) -> IdentificationLog:
    """The log with white Gaussian noise on the odometry: standard deviations position [m], attitude [rad]
    (a small rotation about a random axis), linear velocity [m/s] and angular velocity [rad/s]."""
    rng = np.random.default_rng(seed)
    count = len(log.t)
    quaternions = []
    for row, angles in zip(log.quaternion, rng.normal(0.0, attitude, (count, 3))):
        rotation = pin.Quaternion(np.asarray(row)).toRotationMatrix() @ pin.exp3(angles)
        quaternions.append(pin.Quaternion(rotation).coeffs().copy())
    twist = log.twist + np.hstack([rng.normal(0.0, linear, (count, 3)), rng.normal(0.0, angular, (count, 3))])
    return IdentificationLog(log.t, log.position + rng.normal(0.0, position, (count, 3)), np.array(quaternions),
                             twist, log.wrench, log.joint_names, log.joint_position, log.joint_velocity,
                             f"{log.source} + odometry noise")
