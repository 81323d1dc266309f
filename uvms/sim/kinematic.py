"""The kinematic system (q' = v from a kinematic controller) and the task series of a run.

:class:`KinematicSystem` is what :func:`uvms.sim.loop.simulate` integrates when it is given a ``Robot``;
:class:`TaskSeries` derives the end effector against its desired pose (``simulate(..., task=, desired=)``) from the
stored rows after the loop, for every kind of run.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..control.base import Controller
from ..dynamics.plant.command import State, refuse_fields
from ..errors import ConfigurationError, StepCountError, UVMSError
from ..robot.conventions import wrap_angles
from ..robot.robot import Robot
from ..tasks.frame import FrameTask, matrixToRpy
from .system import StageRate

EMPTY = np.zeros(0)


@dataclass(frozen=True)
class KinematicSample:
    """The controller's velocity at the start of a step: rate = (v (nv,), empty) and its diagnostics."""

    rate: tuple[np.ndarray, np.ndarray]
    info: object


#: What a kinematic plant applies of a Command.
TAKEN = ("velocity",)


class KinematicSystem:
    """q' = v from a controller's ``Command(velocity=v, info=diagnostics)``; no vector state.

    Args:
        robot: the model; controller: a :class:`~uvms.control.base.Controller` whose command's ``info`` has
            sigma_min, damping and limits_active (a SolverResult), asked at every integrator stage.
        control_dt: must be 0: a kinematic controller is evaluated at every integrator stage.

    Raises:
        StepCountError: control_dt not 0.
    """

    def __init__(self, robot: Robot, controller: Controller, control_dt: float = 0.0) -> None:
        if control_dt != 0.0:
            raise StepCountError(f"control_dt must be 0 for a kinematic run (the controller is evaluated at every "
                                 f"integrator stage), got {control_dt!r}; a held command needs a plant")
        self.robot, self.model, self.controller = robot, robot.model, controller

    def initial_state(self, q0: np.ndarray, v0: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """(q0 checked, empty); the controller reset there.

        Raises:
            ConfigurationError: a bad q0, or a v0 (a kinematic run has no velocity state).
        """
        if v0 is not None:
            raise ConfigurationError("v0 is the initial velocity of a plant; a kinematic run has no velocity state "
                                     "(give a Plant to simulate, or leave v0 out)")
        q = self.robot.check_configuration(q0).copy()
        self.controller.reset(State(q), 0.0)
        return q, EMPTY

    def sample(self, t: float, q: np.ndarray, x: np.ndarray) -> KinematicSample:
        """The velocity applied from q at t.

        Raises:
            UVMSError: a command without a velocity, with a field a kinematic plant cannot apply, or a velocity
                not nv finite numbers.
        """
        command = self.controller.command(State(q), t)
        refuse_fields(command, TAKEN, "a kinematic plant", t)
        v = command.velocity
        if v is None or np.shape(v) != (self.model.nv,):
            raise UVMSError(f"the controller must send Command(velocity=...) of {self.model.nv} numbers (the robot's "
                            f"nv) at t = {t:.6g} s, got {v!r}")
        if not all(map(math.isfinite, np.ravel(v).tolist())):  # one pass over Python floats: 0.4 us, not 2.4
            raise UVMSError(f"the controller returned a non-finite velocity at t = {t:.6g} s")
        return KinematicSample((v, EMPTY), command.info)

    def stage_rate(self, sample: KinematicSample) -> StageRate:
        """(t, q, x) -> (the controller's velocity, empty) at the stages: its ``stage_velocity(q, t)`` where it has one
        (the velocity alone, the same numbers: :meth:`uvms.control.tracking.TrackingController.stage_velocity`),
        else its command's."""
        velocity = getattr(self.controller, "stage_velocity", None)
        if velocity is not None:
            return lambda t, q, x: (velocity(q, t), EMPTY)
        command = self.controller.command
        return lambda t, q, x: (command(State(q), t).velocity, EMPTY)

    def record(self, t: float, q: np.ndarray, x: np.ndarray, sample: KinematicSample) -> dict:
        """v and the solver's diagnostics of a row."""
        info = sample.info  # a SolverResult (or anything with its three diagnostics)
        return {"v": sample.rate[0].copy(), "sigma_min": float(info.sigma_min), "damping": float(info.damping),
                "limits_active": len(info.limits_active)}

    def check(self, t: float, q: np.ndarray, x: np.ndarray, dt: float) -> None:
        """Nothing to refuse: the velocity was checked when sampled."""

    def series_info(self) -> dict:
        """No series group: {}."""
        return {}


class TaskSeries:
    """The task series of a run: end-effector pose, desired pose and the errors on the task axes, derived after
    the loop from the stored rows (t, q) in one pass (the loop stores the states only; a row's end effector and
    target are functions of its t and q, never of the controller's state).

    The frame's pose comes from Pinocchio's forward kinematics in a Data of its own moved along the rows (never the
    robot's data; the placements a Configuration computes, bit for bit); the errors are those of
    :meth:`~uvms.tasks.frame.FrameTask.full_error_between`, entry by entry.

    Args:
        robot: the model; task: the end-effector task (its frame, axes and orientation error).
        desired: t [s] -> desired pose of the task frame (world).
    """

    def __init__(self, robot: Robot, task: FrameTask, desired: Callable[[float], pin.SE3]) -> None:
        self.robot, self.task, self.desired = robot, task, desired
        self.position_rows = [r for r in task.rows if r < 3]
        self.orientation_rows = [r for r in task.rows if r >= 3]

    def __call__(self, t: np.ndarray, q: np.ndarray) -> dict[str, np.ndarray]:
        """ee_position, ee_rpy, desired_position, desired_rpy (N, 3) each, task_error (N, k), position_error and
        orientation_error (N,) of the rows t (N,) [s], q (N, nq) (from pin.integrate in the loop: not checked
        again)."""
        task, desired, frame_id = self.task, self.desired, self.task.frame_id
        count = len(t)
        positions, targets = np.empty((count, 3)), np.empty((count, 3))
        pose_rpy, target_rpy = np.empty((count, 3)), np.empty((count, 3))
        errors = np.empty((count, 6))
        log = task.orientation == "log"
        model = self.robot.model
        data, forward, place = model.createData(), pin.forwardKinematics, pin.updateFramePlacement
        for row, (time_, configuration) in enumerate(zip(t.tolist(), q)):
            forward(model, data, configuration)
            pose, target = place(model, data, frame_id), desired(time_)
            rotation, target_rotation = pose.rotation, target.rotation
            positions[row], targets[row] = pose.translation, target.translation
            pose_rpy[row], target_rpy[row] = matrixToRpy(rotation), matrixToRpy(target_rotation)
            if log:  # the numbers of log_pose_error: log3(R_d R^T)
                errors[row, 3:] = pin.log3(target_rotation.dot(rotation.T))
        errors[:, :3] = targets - positions
        if not log:  # the numbers of euler_pose_error, all rows at once
            errors[:, 3:] = wrap_angles(target_rpy - pose_rpy)
        position, orientation = errors[:, self.position_rows], errors[:, self.orientation_rows]
        # sqrt of each row's own dot product: the numbers of one row at a time
        return {"ee_position": positions, "desired_position": targets, "ee_rpy": pose_rpy, "desired_rpy": target_rpy,
                "task_error": np.ascontiguousarray(errors[:, task.rows]),  # row-major, as the rows stacked
                "position_error": np.array([math.sqrt(p.dot(p)) for p in position]),
                "orientation_error": np.array([math.sqrt(o.dot(o)) for o in orientation])}
