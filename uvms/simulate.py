"""Run a velocity controller along a trajectory with a fixed step on the configuration manifold.

Integrators: explicit Euler (as in santos2006) and RK4 in the Munthe-Kaas form
(stages in the tangent space at q_k, mapped with Pinocchio's ``dIntegrate``), so
that the continuous-time CLIK of hoang2011 is integrated to fourth order on the
manifold and not only in a chart.
"""

from __future__ import annotations

import csv
import io
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin


from . import outputs
from .errors import UVMSError
from .integrate import INTEGRATORS, MAX_STEPS, STEPS, check_integrator, step_count
from .robot import Robot
from .tasks.frame import FrameTask
from .tasks.vehicle import VELOCITY_NAMES
from .progress import tqdm

#: A controller maps (q, t) to the velocity v (nv,) and a diagnostics object
#: (a VelocityResult or PriorityResult: fields sigma_min, damping, limits_active).
Controller = Callable[[np.ndarray, float], tuple[np.ndarray, object]]
#: The time series recorded at every step, in the order of the NPZ file.
SERIES = ("t", "q", "v", "ee_position", "ee_rpy", "desired_position", "desired_rpy", "task_error",
          "position_error", "orientation_error", "sigma_min", "damping", "limits_active")


@dataclass
class SimulationResult:
    """Time series of a run; row k is the state at t[k] and the velocity applied from it.

    Attributes:
        t: (N,) [s]; q: (N, nq); v: (N, nv).
        ee_position, desired_position: (N, 3) [m]; ee_rpy, desired_rpy: (N, 3) [rad].
        task_error: (N, k) desired - actual on the task axes [m, rad] (``axes`` names them).
        position_error: (N,) [m] norm over the task's position axes.
        orientation_error: (N,) [rad] norm over the task's orientation axes.
        sigma_min, damping: (N,); limits_active: (N,) number of joints held at a limit.
        robot: the model the run used (not saved).
    """

    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    ee_position: np.ndarray
    ee_rpy: np.ndarray
    desired_position: np.ndarray
    desired_rpy: np.ndarray
    task_error: np.ndarray
    position_error: np.ndarray
    orientation_error: np.ndarray
    sigma_min: np.ndarray
    damping: np.ndarray
    limits_active: np.ndarray
    robot: Robot = field(repr=False)
    axes: tuple[str, ...] = ()
    wall_time: float = 0.0

    def arrays(self) -> dict[str, np.ndarray]:
        """Every saved array by name."""
        return {name: getattr(self, name) for name in SERIES}

    def vehicle_pose(self) -> np.ndarray:
        """Vehicle pose per row: [x, y, yaw] (planar) or [x, y, z, roll, pitch, yaw] (floating), world ENU.

        Angles are unwrapped over time (continuous, not folded into [-pi, pi)).
        """
        rows = []
        for q in self.q:
            pose = self.robot.base_pose(q)
            rpy = pin.rpy.matrixToRpy(pose.rotation)
            rows.append([*pose.translation[:2], rpy[2]] if self.robot.base_type == "planar"
                        else [*pose.translation, *rpy])
        rows = np.array(rows)
        angles = slice(2, 3) if self.robot.base_type == "planar" else slice(3, 6)
        rows[:, angles] = np.unwrap(rows[:, angles], axis=0)
        return rows

    def arm(self) -> np.ndarray:
        """Arm joint values per row (N, n_arm)."""
        return np.array([self.robot.arm_configuration(q) for q in self.q])

    def csv_text(self) -> str:
        """The time series as CSV: t, vehicle pose, arm joints, v, end effector, errors, diagnostics."""
        robot = self.robot
        vehicle_names = (["base_x", "base_y", "base_yaw"] if robot.base_type == "planar" else
                         ["base_x", "base_y", "base_z", "base_roll", "base_pitch", "base_yaw"]
                         if robot.base_type == "floating" else [])
        velocity_names = [f"v_{name}" for name in velocity_labels(robot)]
        header = (["t"] + vehicle_names + robot.arm_joint_names + velocity_names
                  + [f"ee_{a}" for a in ("x", "y", "z", "roll", "pitch", "yaw")]
                  + [f"desired_{a}" for a in ("x", "y", "z", "roll", "pitch", "yaw")]
                  + [f"error_{axis}" for axis in self.axes]
                  + ["position_error", "orientation_error", "sigma_min", "damping", "limits_active"])
        vehicle = self.vehicle_pose() if vehicle_names else np.zeros((len(self.t), 0))
        table = np.column_stack([
            self.t, vehicle, self.arm(), self.v, self.ee_position, self.ee_rpy, self.desired_position,
            self.desired_rpy, self.task_error, self.position_error, self.orientation_error, self.sigma_min, self.damping,
            self.limits_active])
        buffer = io.StringIO()
        writer = csv.writer(buffer, lineterminator="\n")
        writer.writerow(header)
        writer.writerows([[f"{value:.17g}" for value in row] for row in table])
        return buffer.getvalue()

    def save(self, folder: str | os.PathLike) -> tuple[Path, Path]:
        """Write ``trajectory.csv`` and ``trajectory.npz`` atomically into ``folder``."""
        folder = Path(folder)
        outputs.write_text(folder / "trajectory.csv", self.csv_text())
        outputs.write_npz(folder / "trajectory.npz", **self.arrays())
        return folder / "trajectory.csv", folder / "trajectory.npz"


def velocity_labels(robot: Robot) -> list[str]:
    """A name per entry of v: the vehicle's body twist (vx, vy, ... local) then the arm joints."""
    labels = list(VELOCITY_NAMES.get(robot.base_type, ()))
    for joint in robot.arm_joints:
        labels += [joint.name] if joint.nv == 1 else [f"{joint.name}_{i}" for i in range(joint.nv)]
    return labels


def simulate(
    robot: Robot,
    controller: Controller,
    q0: np.ndarray,
    *,
    duration: float,
    dt: float,
    task: FrameTask,
    desired: Callable[[float], pin.SE3],
    integrator: str = "rk4",
    progress: bool | None = None,
) -> SimulationResult:
    """Integrate q' = controller(q, t) from q0 for ``duration`` with step ``dt``.

    Args:
        robot: the model.
        controller: (q, t) -> (v, diagnostics).
        q0: initial configuration (nq,).
        duration, dt: [s]; the number of steps is round(duration / dt), at least 1 and at most
            :data:`MAX_STEPS` (:func:`step_count`).
        task: the end-effector task (its frame and axes define the recorded errors).
        desired: t -> desired pose of the task frame (for the record).
        integrator: "euler" or "rk4".
        progress: show a progress bar (None: only on a terminal).
    """
    check_integrator(integrator)
    steps = step_count(duration, dt)
    q = robot.check_configuration(q0).copy()
    model = robot.model
    position_rows = [r for r in task.rows if r < 3]
    orientation_rows = [r for r in task.rows if r >= 3]
    records: dict[str, list] = {name: [] for name in SERIES}
    started = time.perf_counter()
    empty = np.zeros(0)
    rate = lambda time_, configuration, _: (controller(configuration, time_)[0], empty)  # noqa: E731
    for k in tqdm(range(steps + 1), disable=(not progress) if progress is not None else None,
                  desc="simulate", unit="step", leave=False):
        t = k * dt
        v, info = controller(q, t)
        if not np.all(np.isfinite(v)):
            raise UVMSError(f"the controller returned a non-finite velocity at t = {t:.6g} s")
        pose, target = robot.fk(q, task.frame), desired(t)
        full_error = task.full_error_between(target, pose)
        for name, value in (
            ("t", t), ("q", q.copy()), ("v", v.copy()), ("ee_position", pose.translation.copy()),
            ("ee_rpy", pin.rpy.matrixToRpy(pose.rotation)), ("desired_position", target.translation.copy()),
            ("desired_rpy", pin.rpy.matrixToRpy(target.rotation)), ("task_error", full_error[task.rows]),
            ("position_error", float(np.linalg.norm(full_error[position_rows]))),
            ("orientation_error", float(np.linalg.norm(full_error[orientation_rows]))),
            ("sigma_min", float(np.min(info.sigma_min))), ("damping", float(info.damping)),
            ("limits_active", len(getattr(info, "limits_active", ()))),
        ):
            records[name].append(value)
        if k == steps:
            break
        q, _ = STEPS[integrator](model, rate, t, q, empty, dt, (v, empty))
    arrays = {name: np.array(values) for name, values in records.items()}
    return SimulationResult(**arrays, robot=robot, axes=task.axes, wall_time=time.perf_counter() - started)
