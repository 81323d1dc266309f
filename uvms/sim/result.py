"""The one result type of a run, kinematic or dynamic: time series with optional dynamic extras.

Row k of every series is the state at t[k] and what was applied from it. A kinematic run
(:func:`uvms.sim.simulate.simulate`) fills the task series; a plant run
(:func:`uvms.sim.simulate.simulate_plant`) the plant series; a GJM-controlled plant run
(:func:`uvms.sim.simulate.simulate_gjm`) the plant and the tracking series, and the task series
too when it is given the task (``uvms run``). A series a run did not record is None.
"""

from __future__ import annotations

import csv
import io
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..io import outputs
from ..robot.robot import Robot
from ..tasks.vehicle import VELOCITY_NAMES

#: The time series of a task, in the order of ``trajectory.npz``.
SERIES = ("t", "q", "v", "ee_position", "ee_rpy", "desired_position", "desired_rpy", "task_error",
          "position_error", "orientation_error", "sigma_min", "damping", "limits_active", "objective_value",
          "objective_activation", "objective_active", "speed_ratio")
#: The series of a GJM-controlled plant run, in the order of ``plant.npz``.
PLANT_SERIES = ("t", "q", "v", "command", "rates", "joint_torque", "kinetic_energy", "potential_energy", "momentum",
                "ee_position", "desired_position", "ee_velocity", "desired_velocity", "position_error", "sigma_min",
                "damping")
#: The series of an actuated run that ``save`` writes to ``actuation.npz`` (the others stay in memory).
ACTUATION_SERIES = ("thrusts", "thrust_command", "body_wrench", "wrench_command", "achieved_wrench", "thrust_power",
                    "thruster_power_abs", "damping_power", "vehicle_position_error", "vehicle_attitude_error",
                    "ee_point_error")


@dataclass
class SimulationResult:
    """Time series of a run; row k is the state at t[k] and the velocity (or command) applied from it.

    Attributes:
        t: (N,) [s]; q: (N, nq); v: (N, nv) (kinematic: the velocity applied; dynamic: the state's).
        robot: the model the run used (not saved).
        ee_position, desired_position: (N, 3) [m] world; ee_rpy, desired_rpy: (N, 3) [rad].
        task_error: (N, k) desired - actual on the task axes [m, rad] (``axes`` names them).
        position_error: (N,) [m] norm over the task's position axes.
        orientation_error: (N,) [rad] norm over the task's orientation axes.
        sigma_min, damping: (N,) of the inverted Jacobian; limits_active: (N,) joints held at a limit.
        objective_value, objective_activation: (N, k) the rows of a scenario's inequality objectives (their
            values in their units, activations in [0, 1]); objective_active: (N, n_objectives) bool;
            speed_ratio: (N,) max_i |v_i| / max_i over the speed limits (:mod:`uvms.scenario.inequalities`).
        command: (N, n_arm) joint-velocity commands u [rad/s or m/s] (plant runs).
        joint_torque: (N, n_arm) motor torques [N m or N] (plant runs).
        kinetic_energy, potential_energy: (N,) [J] (plant runs; kinetic includes the added mass).
        momentum: (N, 6) [N s, N m s] world frame about the world origin, rigid + added mass (plant runs).
        rates: (N, n_arm) joint rates w [rad/s] of the controller before the servo feedforward (GJM runs).
        ee_velocity, desired_velocity: (N, 3) [m/s] world, linear velocity of the frame origin (GJM runs).
        axes: the task axes; integrator: "euler" or "rk4"; dt, control_dt, wall_time: [s].
        plant, controller: what produced the run (not saved), or None.
        actuation: the thrusters' and vehicle controller's series of an actuated run (name -> (N, ...) array;
            :data:`ACTUATION_SERIES` are saved), or None; thruster_dynamics: its thrusters (not saved).
    """

    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    ee_position: np.ndarray | None = None
    ee_rpy: np.ndarray | None = None
    desired_position: np.ndarray | None = None
    desired_rpy: np.ndarray | None = None
    task_error: np.ndarray | None = None
    position_error: np.ndarray | None = None
    orientation_error: np.ndarray | None = None
    sigma_min: np.ndarray | None = None
    damping: np.ndarray | None = None
    limits_active: np.ndarray | None = None
    objective_value: np.ndarray | None = None
    objective_activation: np.ndarray | None = None
    objective_active: np.ndarray | None = None
    speed_ratio: np.ndarray | None = None
    robot: Robot = field(default=None, repr=False)
    axes: tuple[str, ...] = ()
    wall_time: float = 0.0
    command: np.ndarray | None = None
    joint_torque: np.ndarray | None = None
    kinetic_energy: np.ndarray | None = None
    potential_energy: np.ndarray | None = None
    momentum: np.ndarray | None = None
    rates: np.ndarray | None = None
    ee_velocity: np.ndarray | None = None
    desired_velocity: np.ndarray | None = None
    integrator: str = "rk4"
    dt: float = 0.0
    control_dt: float = 0.0
    plant: Any = field(default=None, repr=False)
    controller: Any = field(default=None, repr=False)
    actuation: dict[str, np.ndarray] | None = field(default=None, repr=False)
    thruster_dynamics: Any = field(default=None, repr=False)

    # ------------------------------------------------------------------ task series
    def arrays(self) -> dict[str, np.ndarray]:
        """Every task series by name (``trajectory.npz``); those the run did not record are left out."""
        return {name: getattr(self, name) for name in SERIES if getattr(self, name) is not None}

    def vehicle_pose(self) -> np.ndarray:
        """Vehicle pose per row: [x, y, yaw] (planar) or [x, y, z, roll, pitch, yaw] (floating), world ENU.

        Angles are unwrapped over time (continuous, not folded into [-pi, pi)).
        """
        cached = getattr(self, "_vehicle_pose", None)
        if cached is None or cached[0] is not self.q:  # the CSV, the metrics and the figures all read it
            robot = self.robot
            rows = np.array([robot.base_values(q, check=False) for q in self.checked_q()])
            angles = slice(2, 3) if robot.base_type == "planar" else slice(3, 6)
            rows[:, angles] = np.unwrap(rows[:, angles], axis=0)
            cached = self._vehicle_pose = (self.q, rows)
        return cached[1].copy()

    def arm(self) -> np.ndarray:
        """Arm joint values per row (N, n_arm)."""
        robot = self.robot
        return np.array([robot.arm_values(q) for q in self.checked_q()]).reshape(len(self.q), robot.n_arm)

    def checked_q(self) -> np.ndarray:
        """The configurations (N, nq), each checked as :meth:`Robot.check_configuration` does, once per result
        (the rows of a run are read several times: the CSV, the metrics, the figures).

        Raises:
            ConfigurationError: a row of the wrong size, non-finite or with a non-unit rotation part.
        """
        if getattr(self, "_checked_q", None) is not self.q:
            self.robot.check_configurations(self.q)
            self._checked_q = self.q
        return self.q

    def csv_text(self) -> str:
        """The time series as CSV: t, vehicle pose, arm joints, v, end effector, errors, diagnostics (those recorded)."""
        robot = self.robot
        vehicle_names = (["base_x", "base_y", "base_yaw"] if robot.base_type == "planar" else
                         ["base_x", "base_y", "base_z", "base_roll", "base_pitch", "base_yaw"]
                         if robot.base_type == "floating" else [])
        velocity_names = [f"v_{name}" for name in velocity_labels(robot)]
        vehicle = self.vehicle_pose() if vehicle_names else np.zeros((len(self.t), 0))
        columns = [(["t"], self.t), (vehicle_names, vehicle), (robot.arm_joint_names, self.arm()),
                   (velocity_names, self.v),
                   ([f"ee_{a}" for a in ("x", "y", "z")], self.ee_position),
                   ([f"ee_{a}" for a in ("roll", "pitch", "yaw")], self.ee_rpy),
                   ([f"desired_{a}" for a in ("x", "y", "z")], self.desired_position),
                   ([f"desired_{a}" for a in ("roll", "pitch", "yaw")], self.desired_rpy),
                   ([f"error_{axis}" for axis in self.axes], self.task_error),
                   (["position_error"], self.position_error), (["orientation_error"], self.orientation_error),
                   (["sigma_min"], self.sigma_min), (["damping"], self.damping),
                   (["limits_active"], self.limits_active)]
        recorded = [(names, values) for names, values in columns if values is not None]  # e.g. no sigma_min
        header = [name for names, _ in recorded for name in names]
        table = np.column_stack([values for _, values in recorded])
        buffer = io.StringIO()
        writer = csv.writer(buffer, lineterminator="\n")
        writer.writerow(header)
        # one %-format of a whole row: the strings of f"{value:.17g}" (the same C formatting), not a call per value
        row_format = ",".join(["%.17g"] * table.shape[1]) + "\n"
        buffer.writelines([row_format % row for row in map(tuple, table.tolist())])
        return buffer.getvalue()

    def actuation_arrays(self) -> dict[str, np.ndarray]:
        """The arrays of ``actuation.npz``: t and the :data:`ACTUATION_SERIES` the run recorded ({} if not actuated)."""
        if self.actuation is None:
            return {}
        return {"t": self.t, **{name: self.actuation[name] for name in ACTUATION_SERIES if name in self.actuation}}

    def save(self, folder: str | os.PathLike) -> tuple[Path, ...]:
        """Write ``trajectory.csv`` and ``trajectory.npz`` (and an actuated run's ``actuation.npz``) atomically into
        ``folder``; returns their paths."""
        folder = Path(folder)
        outputs.write_text(folder / "trajectory.csv", self.csv_text())
        outputs.write_npz(folder / "trajectory.npz", **self.arrays())
        written = (folder / "trajectory.csv", folder / "trajectory.npz")
        if self.actuation is not None:
            outputs.write_npz(folder / "actuation.npz", **self.actuation_arrays())
            written += (folder / "actuation.npz",)
        return written

    # ------------------------------------------------------------------ plant series
    @property
    def energy(self) -> np.ndarray:
        """Mechanical energy (N,) [J]: kinetic + potential."""
        return self.kinetic_energy + self.potential_energy

    def momentum_drift(self) -> np.ndarray:
        """max_t |h(t) - h(0)| of the linear and the angular momentum (2,) [N s, N m s]."""
        change = self.momentum - self.momentum[0]
        return np.array([np.max(np.linalg.norm(change[:, :3], axis=1)), np.max(np.linalg.norm(change[:, 3:], axis=1))])

    def frame_position(self, frame: str | None = None) -> np.ndarray:
        """Position (N, 3) [m] of any frame (default: the first end effector), world frame."""
        return np.array([self.robot.fk(q, frame).translation for q in self.q])

    def ee_twist(self, frame: str | None = None) -> np.ndarray:
        """Twist (N, 6) [m/s, rad/s] of a frame (default: the first end effector), world-aligned (J v)."""
        return np.array([self.robot.jacobian(q, frame) @ v for q, v in zip(self.q, self.v)])

    def joint_rates(self) -> np.ndarray:
        """Measured joint velocities (N, n_arm) [rad/s]."""
        return self.v[:, self.robot.n_vehicle:]

    def motor_work(self) -> float:
        """Work done by the joint motors, integral of tau_m . qd_m (trapezoid rule) [J]."""
        power = np.sum(self.joint_torque * self.joint_rates(), axis=1)
        return float(np.sum(0.5 * (power[1:] + power[:-1]) * np.diff(self.t))) if len(power) > 1 else 0.0

    # ------------------------------------------------------------------ tracking series (GJM runs)
    def _position_axes(self) -> list[int]:
        return [row for row in self.controller.rows if row < 3]

    def tracking_error(self) -> np.ndarray:
        """(N,) [m] norm of p_d - p over the controller's position axes (``plant.npz``'s position_error)."""
        return np.linalg.norm((self.desired_position - self.ee_position)[:, self._position_axes()], axis=1)

    @property
    def final_position_error(self) -> float:
        """|p_d - p| at the last row [m]."""
        return float(self.position_error[-1])

    @property
    def max_position_error(self) -> float:
        """max_t |p_d - p| [m]."""
        return float(self.position_error.max())

    @property
    def velocity_error(self) -> np.ndarray:
        """(N,) [m/s] norm of v_d - v over the controller's position axes."""
        return np.linalg.norm((self.desired_velocity - self.ee_velocity)[:, self._position_axes()], axis=1)

    def plant_metrics(self) -> dict:
        """Plant-run numbers for ``metrics.json`` (SI units; see the README)."""
        energy = self.energy
        work = self.motor_work()
        rates = self.joint_rates()
        return {
            "final_position_error_xyz": (self.desired_position[-1] - self.ee_position[-1]).tolist(),
            "max_velocity_error": float(self.velocity_error.max()),
            "final_velocity_error": float(self.velocity_error[-1]),
            "momentum_drift": self.momentum_drift().tolist(),
            "final_kinetic_energy": float(self.kinetic_energy[-1]),
            "max_kinetic_energy": float(self.kinetic_energy.max()),
            "motor_work": work,
            "dissipated_energy": float(work - (energy[-1] - energy[0])),
            "max_joint_rate": float(np.abs(rates).max(initial=0.0)),
            "max_joint_command": float(np.abs(self.command).max(initial=0.0)),
            "max_joint_torque": float(np.abs(self.joint_torque).max(initial=0.0)),
        }

    def plant_arrays(self) -> dict[str, np.ndarray]:
        """The series of a GJM-controlled plant run saved in ``plant.npz``."""
        arrays = {name: getattr(self, name) for name in PLANT_SERIES}
        arrays["position_error"] = self.tracking_error()
        return arrays


def velocity_labels(robot: Robot) -> list[str]:
    """A name per entry of v: the vehicle's body twist (vx, vy, ... local) then the arm joints."""
    labels = list(VELOCITY_NAMES.get(robot.base_type, ()))
    for joint in robot.arm_joints:
        labels += [joint.name] if joint.nv == 1 else [f"{joint.name}_{i}" for i in range(joint.nv)]
    return labels
