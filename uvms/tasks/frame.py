"""End-effector (any frame) pose task with axis selection and two orientation errors."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from ..errors import UVMSError
from ..numerics._kernels import Kernel
from ..numerics.validate import finite_array
from ..robot.configuration import Configuration
from ..robot.conventions import pose_from_xyzrpy, wrap_angles
from ..robot.kinematics import axis_rows
from ..robot.robot import Robot, check_robot
from .objectives.frames import FrameReader
from .task import Task

ORIENTATION_ERRORS = ("log", "euler")
matrixToRpy = pin.rpy.matrixToRpy

#: The compiled rows of a frame task (:func:`uvms.numerics._kernels.pose.frame_rows_into`, numba loaded where a task
#: is first evaluated); no rpy: the log error.
_FRAME_ROWS = Kernel("pose", "frame_rows_into")
_NO_RPY = np.zeros(0)


class FrameTask(Task):
    """Drive a frame to a target pose, on any subset of x, y, z, roll, pitch, yaw.

    Position rows: error p_d - p and Jacobian rows of the world-aligned Jacobian.
    Orientation rows, ``orientation="log"``: error log3(R_d R^T) (world axes)
    with the angular Jacobian rows. ``orientation="euler"``: error in
    roll-pitch-yaw (R = Rz(yaw) Ry(pitch) Rx(roll)), wrapped to [-pi, pi), with
    the matching analytic Jacobian E(rpy)^-1 J_omega — the x of hoang2011, whose
    task vector holds angles.

    Args:
        robot: the model.
        frame: frame name (default: the first end effector).
        axes: task axes (default: all six; x, y, yaw for a planar base).
        orientation: "log" or "euler".
        target: target pose, a ``pin.SE3`` or [x, y, z, roll, pitch, yaw] [m, rad].
    """

    def __init__(
        self,
        robot: Robot,
        frame: str | None = None,
        axes: Sequence[str] | None = None,
        orientation: str = "log",
        target: pin.SE3 | Sequence[float] | None = None,
    ) -> None:
        check_robot(robot, "FrameTask")
        if orientation not in ORIENTATION_ERRORS:
            raise UVMSError(f"unknown orientation error {orientation!r}; valid: {', '.join(ORIENTATION_ERRORS)}")
        self.robot = robot
        self.frame = frame or robot.ee_frames[0]
        self.frame_id = robot.frame_id(frame)
        self.axes = tuple(axes or robot.base.task_axes)
        if not self.axes:
            raise UVMSError("a frame task needs at least one axis")
        self.rows = np.array(axis_rows(self.axes), dtype=int)
        self._euler_rows = orientation == "euler" and bool(np.any(self.rows >= 3))  # rows of rpy rates
        self._all_rows = bool(np.array_equal(self.rows, np.arange(6)))
        self.dim = len(self.rows)
        self.orientation = orientation
        self._translation: np.ndarray | None = None  # the target pose's arrays (3,) [m], (3, 3)
        self._rotation: np.ndarray | None = None
        self._target_rpy: np.ndarray | None = None  # its rpy [rad] when the setter knew them
        self.target_twist = np.zeros(6)
        self._target_parts: tuple | None = None  # what terms() reads of the target, once per set_target
        # position rows, or Euler orientation rows, and no mimic joint: terms() forms them from the joint kinematics
        # in one compiled call (getFrameJacobian's, the frame placement's, matrixToRpy's and
        # computeRpyJacobianInverse's numbers); a log orientation row keeps Pinocchio's log3
        self._frame = FrameReader(robot, self.frame_id)  # its joint, placement in it and support (the objectives')
        self._compiled_rows = (not np.any(self.rows >= 3) or orientation == "euler") and self._frame.joint is not None
        if target is not None:
            self.set_target(target)

    @property
    def target(self) -> pin.SE3 | None:
        """The target pose (a new ``pin.SE3`` at each read), None before one is set."""
        return None if self._rotation is None else pin.SE3(self._rotation, self._translation)

    def set_target(self, target: pin.SE3 | Sequence[float]) -> None:
        """Set the target pose (``pin.SE3`` or [x, y, z, roll, pitch, yaw])."""
        if not isinstance(target, pin.SE3):
            try:
                values = finite_array(target, "a target pose", (6,))
            except UVMSError:  # the message of a pose: what the six numbers are, and that a pin.SE3 serves
                raise UVMSError(f"a target pose must be a pin.SE3 or 6 finite numbers [x, y, z, roll, pitch, yaw], "
                                f"got {target!r}") from None
            target = pose_from_xyzrpy(values)
        # copies (a pose's arrays are views of it), the rotation in its layout (column-major)
        self._translation, self._rotation = target.translation.copy(), target.rotation.copy(order="K")
        self._target_rpy = None
        self._target_parts = None

    def follow(self, translation: np.ndarray, rotation: np.ndarray, twist: np.ndarray,
               rpy: np.ndarray | None = None) -> None:
        """Set the target pose and twist from a trajectory's arrays, taken as they are (neither copied nor checked:
        a trajectory table's rows, which no one writes; the one loop refuses any non-finite velocity).

        Args:
            translation: p_d (3,) [m]; rotation: R_d (3, 3); twist: [v; omega] (6,) in world axes [m/s, rad/s].
            rpy: the roll-pitch-yaw of R_d (3,) [rad] when the caller has them (else computed when needed).
        """
        self._translation, self._rotation, self._target_rpy = translation, rotation, rpy
        self.target_twist = twist
        self._target_parts = None

    def set_target_velocity(self, twist: Sequence[float], *, check: bool = True) -> None:
        """Set the target twist [v; omega] (6,) in world axes (feedforward).

        ``check=False`` takes a float array (6,) as it is: a trajectory's samples in the one loop, which
        refuses any non-finite velocity it would integrate."""
        if not check:
            self.target_twist = twist
            self._target_parts = None
            return
        try:
            values = finite_array(twist, "a target twist", (6,))
        except UVMSError:
            raise UVMSError("a target twist must be 6 finite numbers [vx, vy, vz, wx, wy, wz], "
                            f"got {twist!r}") from None
        self.target_twist = values
        self._target_parts = None

    def _target(self) -> pin.SE3:
        if self._rotation is None:
            raise UVMSError(f"frame task on {self.frame!r} has no target: call set_target() first")
        return self.target  # type: ignore[return-value]

    def full_error(self, state: Configuration) -> np.ndarray:
        """All six error rows (6,): position then orientation."""
        return self.full_error_between(self._target(), state.pose(self.frame_id))

    def full_error_between(self, target: pin.SE3, pose: pin.SE3, target_rpy: np.ndarray | None = None,
                           pose_rpy: np.ndarray | None = None) -> np.ndarray:
        """Six error rows (6,) of ``pose`` with respect to ``target``, in this task's orientation form (the rpy (3,)
        of both [rad], when the caller has them, serve the Euler error)."""
        if self.orientation == "log":
            return log_pose_error(target.translation, target.rotation, pose)
        return euler_pose_error(target.translation, pose,
                                matrixToRpy(target.rotation) if target_rpy is None else target_rpy,
                                matrixToRpy(pose.rotation) if pose_rpy is None else pose_rpy)

    def error(self, state: Configuration) -> np.ndarray:
        return self.full_error(state)[self.rows]

    def jacobian(self, state: Configuration) -> np.ndarray:
        jacobian = state.jacobian(self.frame_id)
        if self._euler_rows:
            jacobian = self._euler_jacobian(jacobian, matrixToRpy(state.pose(self.frame_id).rotation))
        return jacobian[self.rows]

    @staticmethod
    def _euler_jacobian(jacobian: np.ndarray, pose_rpy: np.ndarray) -> np.ndarray:
        """A copy of the world-aligned J (6, nv) with its angular rows as rpy rates: E(rpy)^-1 J_omega, each entry
        summed in index order (the numbers of a prepared CLIK step; BLAS would sum with fused products)."""
        rates = pin.rpy.computeRpyJacobianInverse(pose_rpy, pin.WORLD)  # (3, 3)
        jacobian = jacobian.copy()
        angular = jacobian[3:]  # the right side is computed before it is written
        jacobian[3:] = rates[:, :1] * angular[0] + rates[:, 1:2] * angular[1] + rates[:, 2:] * angular[2]
        return jacobian

    def feedforward(self, state: Configuration) -> np.ndarray:
        if self.orientation == "euler":
            return self._euler_feedforward(matrixToRpy(self._target().rotation))[self.rows]
        return self.target_twist[self.rows]

    def _euler_feedforward(self, target_rpy: np.ndarray) -> np.ndarray:
        """The target twist (6,) with its angular part as rpy rates [m/s, rad/s]."""
        feedforward = self.target_twist.copy()
        omega = feedforward[3:]
        if omega[0] != 0.0 or omega[1] != 0.0 or omega[2] != 0.0:  # a constant orientation has no rpy rates to map
            feedforward[3:] = pin.rpy.computeRpyJacobianInverse(target_rpy, pin.WORLD) @ omega
        return feedforward

    def target_terms(self) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray]:
        """(p_d (3,) [m], R_d (3, 3), rpy_d (3,) [rad] or None, feedforward rows (k,)) of the target, read once per
        target (a controller's integrator evaluates several stages at one target; a prepared CLIK step reads them).

        Raises:
            UVMSError: no target set.
        """
        if self._target_parts is None:
            translation, rotation = self._translation, self._rotation
            if rotation is None:
                self._target()  # raises: no target
            if self.orientation == "log":
                self._target_parts = (translation, rotation, None, self.target_twist[self.rows])
            else:
                target_rpy = matrixToRpy(rotation) if self._target_rpy is None else self._target_rpy
                self._target_parts = (translation, rotation, target_rpy,
                                      self._euler_feedforward(target_rpy)[self.rows])
        return self._target_parts

    def terms(self, state: Configuration) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(jacobian (k, nv), error (k,), feedforward (k,)) at once: each rotation read and each rpy computed once."""
        translation, rotation, target_rpy, feedforward = self.target_terms()
        if self._compiled_rows:  # (:func:`~uvms.numerics._kernels.pose.frame_rows_into`)
            jacobian, error = np.empty((self.dim, state.model.nv)), np.empty(self.dim)
            kernel = _FRAME_ROWS.function or _FRAME_ROWS.load()
            frame = self._frame
            kernel(*state.joint_arrays(frame.joint), frame.placement, frame.columns, self.rows, translation, rotation,
                   target_rpy if self._euler_rows else _NO_RPY, jacobian, error)
            return jacobian, error, feedforward.copy()
        pose = state.pose(self.frame_id)
        jacobian = state.jacobian(self.frame_id)
        if self.orientation == "log":
            error = log_pose_error(translation, rotation, pose)
            if self._all_rows:  # a fresh copy either way; a copy costs less than taking all six rows by index
                return jacobian.copy(), error, feedforward.copy()
            return jacobian[self.rows], error[self.rows], feedforward.copy()
        pose_rpy = matrixToRpy(pose.rotation)
        if self._euler_rows:
            jacobian = self._euler_jacobian(jacobian, pose_rpy)
        return (jacobian[self.rows], euler_pose_error(translation, pose, target_rpy, pose_rpy)[self.rows],
                feedforward.copy())


def log_pose_error(target_translation: np.ndarray, target_rotation: np.ndarray, pose: pin.SE3) -> np.ndarray:
    """[p_d - p; log3(R_d R^T)] (6,) [m, rad] in world axes of ``pose`` against the target p_d (3,), R_d (3, 3)."""
    homogeneous = pose.homogeneous  # (4, 4): one conversion for both parts (.translation and .rotation: two)
    error = np.empty(6)
    error[:3] = target_translation - homogeneous[:3, 3]
    error[3:] = pin.log3(target_rotation.dot(homogeneous[:3, :3].T))  # the numbers of R_d @ R.T, bit for bit
    return error


def euler_pose_error(target_translation: np.ndarray, pose: pin.SE3, target_rpy: np.ndarray,
                     pose_rpy: np.ndarray) -> np.ndarray:
    """[p_d - p; rpy_d - rpy wrapped to [-pi, pi)] (6,) [m, rad] (the rpy of both given, (3,) each)."""
    error = np.empty(6)
    error[:3] = target_translation - pose.translation
    error[3:] = wrap_angles(target_rpy - pose_rpy)
    return error
