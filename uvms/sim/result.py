"""The one result type of a run: time series, with the optional series groups of a plant, a tracking controller
and thrusters (:mod:`uvms.sim.series`).

Row k of every series is the state at t[k] and what was applied from it. A kinematic run fills the task series;
a plant run the plant series (``plant``); a run of a tracking controller (the GJM controller) the tracking series
(``tracking``) too; a plant with thrusters the actuation series (``actuation``). The task series need the run's
task (``simulate(..., task=, desired=)``). A series a run did not record is None. A result is immutable: built
once at the end of :func:`uvms.sim.loop.simulate`, never changed (``dataclasses.replace`` makes another).
"""

from __future__ import annotations

import csv
import io
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import UVMSError
from ..io import outputs
from ..robot.configuration import configurations
from ..robot.robot import Robot
from ..tasks.vehicle import VELOCITY_NAMES
from .series import ACTUATION_FIELDS, PLANT_FIELDS, TRACKING_FIELDS, ActuationSeries, PlantSeries, TrackingSeries

#: The time series of a task, in the order of ``trajectory.npz``.
SERIES = ("t", "q", "v", "ee_position", "ee_rpy", "desired_position", "desired_rpy", "task_error",
          "position_error", "orientation_error", "sigma_min", "damping", "limits_active", "objective_value",
          "objective_activation", "objective_active", "objective_pair", "speed_ratio")
#: The series of a tracking-controlled plant run, in the order of ``plant.npz``.
PLANT_SERIES = ("t", "q", "v", "command", "rates", "joint_torque", "kinetic_energy", "potential_energy", "momentum",
                "ee_position", "desired_position", "ee_velocity", "desired_velocity", "position_error", "sigma_min",
                "damping")


@dataclass(frozen=True)
class SimulationResult:
    """Time series of a run; row k is the state at t[k] and the velocity (or command) applied from it.

    Attributes:
        t: (N,) [s]; q: (N, nq); v: (N, nv) (kinematic: the velocity applied; dynamic: the state's).
        ee_position, desired_position: (N, 3) [m] world; ee_rpy, desired_rpy: (N, 3) [rad].
        task_error: (N, k) desired - actual on the task axes [m, rad] (``axes`` names them).
        position_error: (N,) [m] norm over the task's position axes (a tracking run without task: the
            controller's, ``tracking.position_error``).
        orientation_error: (N,) [rad] norm over the task's orientation axes.
        sigma_min, damping: (N,) of the inverted Jacobian; limits_active: (N,) joints held at a limit.
        objective_value, objective_activation: (N, k) the rows of a scenario's inequality objectives (their
            values in their units, activations in [0, 1]); objective_active: (N, n_objectives) bool;
            objective_pair: (N, k_pairs) int, per row of a collision objective the index of its pair of shapes
            (in the objective's ``links``), the collision objectives' rows in order;
            speed_ratio: (N,) max_i ``|v_i|`` / max_i over the speed limits (:mod:`uvms.scenario.inequalities`).
        robot: the model the run used (not saved); axes: the task axes; integrator: "euler" or "rk4";
            dt, wall_time: [s].
        plant: the plant series (plant runs), tracking: the tracking controller's, actuation: the thrusters'
            and the vehicle controller's (actuated runs); None when the run had none.
    """

    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    robot: Robot = field(repr=False)
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
    objective_pair: np.ndarray | None = None
    speed_ratio: np.ndarray | None = None
    axes: tuple[str, ...] = ()
    integrator: str = "rk4"
    dt: float = 0.0
    wall_time: float = 0.0
    plant: PlantSeries | None = field(default=None, repr=False)
    tracking: TrackingSeries | None = field(default=None, repr=False)
    actuation: ActuationSeries | None = field(default=None, repr=False)
    _vehicle: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        """Check the configurations once (:meth:`Robot.check_configurations`) and derive the vehicle pose series.

        Raises:
            ConfigurationError: a row of q of the wrong size, non-finite or with a non-unit rotation part.
        """
        robot = self.robot
        robot.check_configurations(self.q)
        rows = robot.base_values_rows(self.q)
        if robot.base_type != "fixed":
            angles = slice(2, 3) if robot.base_type == "planar" else slice(3, 6)
            rows[:, angles] = np.unwrap(rows[:, angles], axis=0)
        object.__setattr__(self, "_vehicle", rows)

    @classmethod
    def from_rows(cls, arrays: dict[str, np.ndarray], info: dict[str, Any], **fields: Any) -> SimulationResult:
        """The result of the loop's rows: each series to its field or group.

        Args:
            arrays: the series by name, N rows each (:func:`uvms.sim.loop.run_loop`).
            info: the system's :meth:`uvms.sim.system.System.series_info` (tracking frame and rows, thrust bounds).
            fields: robot, axes, integrator, dt, wall_time.

        Raises:
            UVMSError: a series no field or group holds (a recorder's name that is not a series of the result).
        """
        arrays = dict(arrays)
        count = len(arrays["t"])
        plant = tracking = actuation = None
        recorded: dict[str, np.ndarray] = {}  # the plant's own rows, which an actuation's derived series read
        if "joint_torque" in arrays:
            for name in ("command", "joint_torque"):  # no arm: (N, 0)
                arrays[name] = arrays[name].reshape(count, -1)
            given = {name: arrays.pop(name) for name in PLANT_FIELDS if name in arrays}
            recorded.update(given)
            derive = info.get("plant_series")
            states = (arrays["q"], arrays["v"])
            plant = PlantSeries(**given, derive=None if derive is None else lambda: derive(*states))
        if "tracking" in info:
            frame, rows = info["tracking"]
            tracking = TrackingSeries(ee_position=arrays["ee_position"], desired_position=arrays["desired_position"],
                                      **{name: arrays.pop(name) for name in TRACKING_FIELDS}, frame=frame,
                                      position_rows=tuple(row for row in rows if row < 3))
            arrays.setdefault("position_error", tracking.position_error)
        if "thrust_bounds" in info:
            lower, upper = info["thrust_bounds"]
            own = {name: arrays.pop(name) for name in ACTUATION_FIELDS if name in arrays}
            derive_actuation = info.get("actuation_series")  # the series of the stored rows (wrench, powers)
            if derive_actuation is not None:
                rows = {**recorded, **own, **{name: arrays[name] for name in ("fin_wrench",) if name in arrays}}
                own.update(derive_actuation(arrays["q"], arrays["v"], rows))
            derive_controller = info.get("controller_series")  # the controller's, of the stored rows
            if derive_controller is not None:
                for name, values in derive_controller(arrays["t"], arrays["q"]).items():
                    arrays.setdefault(name, values)  # a series the run derived already (a task's) is kept
            others = {name: arrays.pop(name) for name in list(arrays) if name not in SERIES}
            actuation = ActuationSeries(**own, lower=lower, upper=upper, controller=others)
        unknown = sorted(set(arrays) - set(SERIES))
        if unknown:
            raise UVMSError(f"the run recorded {', '.join(unknown)}, which no series of SimulationResult holds; "
                            f"a recorder may return {', '.join(SERIES[3:])}")
        return cls(**arrays, plant=plant, tracking=tracking, actuation=actuation, **fields)

    # ------------------------------------------------------------------ task series
    def arrays(self) -> dict[str, np.ndarray]:
        """Every task series by name (``trajectory.npz``); those the run did not record are left out."""
        return {name: getattr(self, name) for name in SERIES if getattr(self, name) is not None}

    def vehicle_pose(self) -> np.ndarray:
        """Vehicle pose per row: [x, y, yaw] (planar) or [x, y, z, roll, pitch, yaw] (floating), world ENU.

        Angles are unwrapped over time (continuous, not folded into [-pi, pi)).
        """
        return self._vehicle.copy()

    def arm(self) -> np.ndarray:
        """Arm joint values per row (N, n_arm)."""
        return self.robot.arm_values(self.q)

    def csv_text(self) -> str:
        """The time series as CSV: t, vehicle pose, arm joints, v, end effector, errors, diagnostics (as recorded)."""
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
        # one %-format of every row at once: the strings of f"{value:.17g}" (the same C formatting), not a call per
        # value, and no list or tuple per row (thousands of them would set off the collector's full passes)
        row_format = ",".join(["%.17g"] * table.shape[1]) + "\n"
        buffer.write((row_format * table.shape[0]) % tuple(table.ravel().tolist()))
        return buffer.getvalue()

    def save(self, folder: str | os.PathLike) -> tuple[Path, ...]:
        """Write ``trajectory.csv`` and ``trajectory.npz`` (and an actuated run's ``actuation.npz``: t and
        :meth:`ActuationSeries.arrays`) atomically into ``folder``; returns their paths."""
        folder = Path(folder)
        # zlib releases the GIL: the npz compresses on a second core while the CSV's numbers are formatted
        with ThreadPoolExecutor(max_workers=1) as pool:
            npz = pool.submit(outputs.write_npz, folder / "trajectory.npz", **self.arrays())
            outputs.write_text(folder / "trajectory.csv", self.csv_text())
            npz.result()
        written = (folder / "trajectory.csv", folder / "trajectory.npz")
        if self.actuation is not None:
            outputs.write_npz(folder / "actuation.npz", t=self.t, **self.actuation.arrays())
            written += (folder / "actuation.npz",)
        return written

    # ------------------------------------------------------------------ plant series
    def frame_position(self, frame: str | None = None) -> np.ndarray:
        """Position (N, 3) [m] of any frame (default: the first end effector), world frame."""
        frame_id = self.robot.frame_id(frame)
        return np.array([state.pose(frame_id).translation.copy() for state in configurations(self.robot, self.q)])

    def ee_twist(self, frame: str | None = None) -> np.ndarray:
        """Twist (N, 6) [m/s, rad/s] of a frame (default: the first end effector), world-aligned (J v)."""
        frame_id = self.robot.frame_id(frame)
        return np.array([state.jacobian(frame_id) @ v for state, v in zip(configurations(self.robot, self.q), self.v)])

    def joint_rates(self) -> np.ndarray:
        """Measured joint velocities (N, n_arm) [rad/s]."""
        return self.v[:, self.robot.n_vehicle:]

    def motor_work(self) -> float:
        """Work done by the joint motors, integral of tau_m . qd_m (trapezoid rule) [J] (plant runs)."""
        power = np.sum(self._group("plant").joint_torque * self.joint_rates(), axis=1)
        return float(np.sum(0.5 * (power[1:] + power[:-1]) * np.diff(self.t))) if len(power) > 1 else 0.0

    @property
    def final_position_error(self) -> float:
        """``|p_d - p|`` at the last row [m]."""
        return float(self.position_error[-1])

    @property
    def max_position_error(self) -> float:
        """max_t ``|p_d - p|`` [m]."""
        return float(self.position_error.max())

    def plant_metrics(self) -> dict:
        """Numbers of a tracking-controlled plant run for ``metrics.json`` (SI units; see the README)."""
        plant, tracking = self._group("plant"), self._group("tracking")
        energy = plant.energy
        work = self.motor_work()
        rates = self.joint_rates()
        velocity_error = tracking.velocity_error
        return {
            "final_position_error_xyz": (self.desired_position[-1] - self.ee_position[-1]).tolist(),
            "max_velocity_error": float(velocity_error.max()),
            "final_velocity_error": float(velocity_error[-1]),
            "momentum_drift": plant.momentum_drift().tolist(),
            "final_kinetic_energy": float(plant.kinetic_energy[-1]),
            "max_kinetic_energy": float(plant.kinetic_energy.max()),
            "motor_work": work,
            "dissipated_energy": float(work - (energy[-1] - energy[0])),
            "max_joint_rate": float(np.abs(rates).max(initial=0.0)),
            "max_joint_command": float(np.abs(plant.command).max(initial=0.0)),
            "max_joint_torque": float(np.abs(plant.joint_torque).max(initial=0.0)),
        }

    def plant_arrays(self) -> dict[str, np.ndarray]:
        """The :data:`PLANT_SERIES` of a tracking-controlled plant run, saved in ``plant.npz``."""
        plant, tracking = self._group("plant"), self._group("tracking")
        groups = {"plant": plant, "tracking": tracking}
        arrays = {}
        for name in PLANT_SERIES:
            owner = next((group for group in groups.values() if hasattr(group, name)), self)
            arrays[name] = getattr(owner, name)
        arrays["position_error"] = tracking.position_error
        return arrays

    def actuation_metrics(self) -> dict:
        """The actuated run's numbers for ``metrics.json`` (:meth:`uvms.sim.series.ActuationSeries.metrics`)."""
        return self._group("actuation").metrics(self.t)

    def _group(self, name: str) -> Any:
        group = getattr(self, name)
        if group is None:
            raise UVMSError(f"this run has no {name} series (recorded: task series"
                            f"{''.join(', ' + n for n in ('plant', 'tracking', 'actuation') if getattr(self, n))})")
        return group


def velocity_labels(robot: Robot) -> list[str]:
    """A name per entry of v: the vehicle's body twist (vx, vy, ... local) then the arm joints."""
    labels = list(VELOCITY_NAMES.get(robot.base_type, ()))
    for joint in robot.arm_joints:
        labels += [joint.name] if joint.nv == 1 else [f"{joint.name}_{i}" for i in range(joint.nv)]
    return labels
