"""Geometric inequality objectives: vehicle tilt, clearance from a plane, a frame inside a box."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ...errors import FrameNotFound, ObjectiveError
from ...numerics._kernels import Kernel
from ...numerics.validate import finite_array
from ...robot.configuration import Configuration
from ...robot.kinematics import support_columns
from ...robot.robot import Robot
from .base import Inequality, InequalityRows, finite_number, vehicle_frame_id

#: Below this tilt [rad] the tilt's gradient is undefined (a cone's apex); the Jacobian row is taken as 0.
LEVEL_TILT = 1e-9


#: The compiled rows of the tilt and of a plane clearance (:mod:`uvms.numerics._kernels.objectives`, numba loaded
#: where an objective is first evaluated).
_TILT_ROWS = Kernel("objectives", "tilt_rows_into")
_CLEARANCE_ROWS = Kernel("objectives", "clearance_rows_into")


class FrameReader:
    """How a task or objective reads its frame at a configuration: from the joint kinematics the configuration
    computed once for all its readers (its joint's placement and every joint's world Jacobian, Pinocchio's ``data.J``)
    and the frame's placement in its joint, in Pinocchio's arithmetic; on a model with mimic joints (whose columns are
    not their joints' own) from Pinocchio's frame pose and Jacobian. The same numbers either way.

    Args:
        robot: the model; frame_id: the frame.
    """

    def __init__(self, robot: Robot, frame_id: int) -> None:
        frame = robot.model.frames[frame_id]
        self.frame_id = frame_id
        self.joint = None if robot.mimic_joint_names else int(frame.parentJoint)
        self.placement = np.ascontiguousarray(frame.placement.homogeneous)  # (4, 4)
        self.columns = (np.arange(robot.nv, dtype=np.int64) if self.joint is None
                        else support_columns(robot.model, self.joint))  # (m,) the columns that move the frame
        self._axis = frame.placement.rotation[:, 2].tolist()  # the frame's z axis in its joint

    def z_axis(self, state: Configuration) -> tuple[float, float, float]:
        """The frame's z axis in world axes: column 2 of R_joint R_placement, each entry summed as Pinocchio's SE3
        product sums it (:func:`~uvms.numerics._kernels.pose.row_product`: rows 0 and 1 as (a + b) + c, row 2 as
        a + (b + c))."""
        if self.joint is None:
            return tuple(state.pose(self.frame_id).rotation[:, 2].tolist())
        rotation = state.joint_arrays(self.joint)[2].tolist()
        a, b, c = self._axis
        return ((rotation[0][0] * a + rotation[0][1] * b) + rotation[0][2] * c,
                (rotation[1][0] * a + rotation[1][1] * b) + rotation[1][2] * c,
                rotation[2][0] * a + (rotation[2][1] * b + rotation[2][2] * c))

    def jacobians(self, state: Configuration) -> tuple[np.ndarray, np.ndarray]:
        """(Jacobians (6, nv), columns) as the objectives' kernels read the frame's rows: the joints' world Jacobian and
        the frame's support, or the frame's own world-aligned Jacobian and every column."""
        if self.joint is None:
            return state.jacobian(self.frame_id), self.columns
        return state.joint_arrays(self.joint)[0], self.columns

    def arrays(self, state: Configuration) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, bool]:
        """(R (3, 3), t (3,), placement (4, 4), Jacobians (6, nv), columns, at the joint) as the objectives' kernels
        read them: the joint's placement and the joints' world Jacobian (at the joint: True), or the frame's pose and
        its own world-aligned Jacobian (False)."""
        if self.joint is None:
            pose = state.pose(self.frame_id)
            return pose.rotation, pose.translation, self.placement, state.jacobian(self.frame_id), self.columns, False
        jacobians, translation, rotation = state.joint_arrays(self.joint)
        return rotation, translation, self.placement, jacobians, self.columns, True


class VehicleAttitude(Inequality):
    """Keep the vehicle level: tilt <= max_tilt, tilt = the angle between the vehicle's z axis and world z.

    The tilt combines roll and pitch (cos tilt = cos roll cos pitch, yaw free). With z_b the body z axis
    in world axes and omega the vehicle's angular velocity (world axes, from Pinocchio's world-aligned
    Jacobian of the vehicle body frame), d tilt/dt = -u . omega, ``u = (z_b x e_z) / |z_b x e_z|``.
    At tilt = 0 the gradient is undefined and taken as 0 (the objective is inactive there).

    Args:
        robot: a model with a floating base (a planar vehicle cannot tilt).
        max_tilt: the largest tilt allowed [rad], in (0, pi/2].
        band: activation band [rad] > 0, at most max_tilt (default max_tilt / 2).
        gain: reference gain [1/s].
        shape: activation shape, "cosine" or "step".
        name: the name results report.
    """

    type_name = "vehicle_attitude"
    unit = "tilt [deg]"

    def shown(self, value: np.ndarray) -> np.ndarray:
        """The tilt in degrees."""
        return np.degrees(value)

    def __init__(self, robot: Robot, max_tilt: float, band: float | None = None, gain: float = 1.0,
                 shape: str = "cosine", name: str = "vehicle_attitude") -> None:
        self.name = name
        if robot.base_type != "floating":
            raise ObjectiveError(f"{name}: needs a floating base, {robot.name} has a {robot.base_type} one "
                                 f"(a planar vehicle cannot tilt)")
        self.frame_id = vehicle_frame_id(robot, name)
        self._frame = FrameReader(robot, self.frame_id)
        max_tilt = finite_number(max_tilt, f"{name}: max_tilt", positive=True)
        if max_tilt > np.pi / 2:
            raise ObjectiveError(f"{name}: max_tilt must be in (0, pi/2] [rad], got {max_tilt!r}")
        band = 0.5 * max_tilt if band is None else finite_number(band, f"{name}: band", positive=True)
        if band > max_tilt:
            raise ObjectiveError(f"{name}: band {band} must not exceed max_tilt {max_tilt} [rad]")
        self.max_tilt = max_tilt
        self._set_valid_set([-np.inf], [max_tilt], band, gain, shape)

    def value(self, state: Configuration) -> np.ndarray:
        """The tilt (1,) [rad] alone (a recorder reads it at every row: no Jacobian)."""
        return _tilt(self._frame.z_axis(state)[2])

    def jacobian(self, state: Configuration) -> np.ndarray:
        return self.value_jacobian(state)[1]

    def value_jacobian(self, state: Configuration) -> tuple[np.ndarray, np.ndarray]:
        """(tilt (1,), its Jacobian (1, nv)) from one read of the vehicle's pose."""
        jacobian = np.empty((1, state.robot.nv))
        tilt = self._tilt_rows(state, jacobian[0], np.empty(1), np.empty(1))
        return tilt, jacobian

    def rows_into(self, state: Configuration, jacobian: np.ndarray, activation: np.ndarray,
                  reference: np.ndarray) -> InequalityRows:
        """:meth:`rows` written into a solver's stacked rows (one compiled call)."""
        return InequalityRows(self.name, self._tilt_rows(state, jacobian[0], activation, reference), jacobian,
                              self.lower, self.upper, activation, reference, self.gain)

    def _tilt_rows(self, state: Configuration, row: np.ndarray, activation: np.ndarray,
                   reference: np.ndarray) -> np.ndarray:
        """The tilt (1,) [rad]; its row d tilt / dt (nv,), activation and reference (1,) written
        (:func:`~uvms.numerics._kernels.objectives.tilt_rows_into`)."""
        frame = self._frame
        x, y, z = frame.z_axis(state)  # the body z axis in world axes
        tilt = _tilt(z)
        kernel = _TILT_ROWS.function or _TILT_ROWS.load()
        kernel(x, y, tilt, *frame.jacobians(state), LEVEL_TILT, self._bounds, self.gain, self._step, row, activation,
               reference)
        return tilt


def _tilt(z: float) -> np.ndarray:
    """The angle (1,) [rad] between a body z axis in world axes and the world's z, from the axis' world z [-]
    (numpy's arccos: its numbers)."""
    return np.array([np.arccos(min(max(z, -1.0), 1.0))])


class PlaneClearance(Inequality):
    """A frame (or the vehicle) at least ``min`` from a plane: n . (p - p0) >= min (1 row).

    Args:
        robot: the model.
        frame: a frame name, or "vehicle" for the vehicle body (floating or planar base).
        point: a point p0 of the plane (3,) [m], world.
        normal: the plane's normal n (3,) (normalized here), pointing to the allowed side.
        min: the smallest signed distance allowed [m].
        band: activation band [m] > 0.
        gain: reference gain [1/s].
        shape: activation shape, "cosine" or "step".
        name: the name results report (default ``plane_clearance(<frame>)``).
    """

    type_name = "plane_clearance"
    unit = "distance [m]"
    min_metric = "min_clearance"

    def __init__(self, robot: Robot, frame: str, point: Sequence[float], normal: Sequence[float],
                 min: float = 0.0, band: float = 0.2, gain: float = 1.0, shape: str = "cosine",  # noqa: A002
                 name: str | None = None) -> None:
        self.name = name or f"plane_clearance({frame})"
        self.frame = frame
        if frame == "vehicle":
            self.frame_id = vehicle_frame_id(robot, f"{self.name} of 'vehicle'")
        elif isinstance(frame, str) and robot.model.existFrame(frame):
            self.frame_id = robot.frame_id(frame)
        else:
            raise FrameNotFound(str(frame), ["vehicle", *robot.frame_names], first=["vehicle"])
        self._frame = FrameReader(robot, self.frame_id)
        self.point = finite_array(point, f"{self.name}: point", (3,), error=ObjectiveError, unit=" [m]")
        normal = finite_array(normal, f"{self.name}: normal", (3,), error=ObjectiveError)
        length = np.linalg.norm(normal)
        if length < 1e-12:
            raise ObjectiveError(f"{self.name}: the normal must be a non-zero vector, got {normal.tolist()}")
        self.normal = normal / length
        self.min = finite_number(min, f"{self.name}: min")
        self._set_valid_set([self.min], [np.inf], finite_number(band, f"{self.name}: band", positive=True),
                            gain, shape)

    def value(self, state: Configuration) -> np.ndarray:
        return np.array([self.normal @ (state.pose(self.frame_id).translation - self.point)])

    def jacobian(self, state: Configuration) -> np.ndarray:
        return (self.normal @ state.jacobian(self.frame_id)[:3])[None, :]

    def value_jacobian(self, state: Configuration) -> tuple[np.ndarray, np.ndarray]:
        """(n . (p - p0) (1,), n^T J_p (1, nv)): :meth:`value` and :meth:`jacobian` in one call (a solver's step)."""
        value, jacobian = np.empty(1), np.empty((1, state.robot.nv))
        self._clearance_rows(state, value, jacobian[0], np.empty(1), np.empty(1))
        return value, jacobian

    def rows_into(self, state: Configuration, jacobian: np.ndarray, activation: np.ndarray,
                  reference: np.ndarray) -> InequalityRows:
        """:meth:`rows` written into a solver's stacked rows (one compiled call)."""
        value = np.empty(1)
        self._clearance_rows(state, value, jacobian[0], activation, reference)
        return InequalityRows(self.name, value, jacobian, self.lower, self.upper, activation, reference, self.gain)

    def _clearance_rows(self, state: Configuration, value: np.ndarray, row: np.ndarray, activation: np.ndarray,
                        reference: np.ndarray) -> None:
        """n . (p - p0) into ``value`` (1,), n^T J_p into ``row`` (nv,), the activation and reference (1,)
        (:func:`~uvms.numerics._kernels.objectives.clearance_rows_into`)."""
        kernel = _CLEARANCE_ROWS.function or _CLEARANCE_ROWS.load()
        kernel(self.normal, *self._frame.arrays(state), self.point, self._bounds, self.gain, self._step, value, row,
               activation, reference)


class FrameBox(Inequality):
    """A frame's position inside a box lower <= p <= upper (3 rows, world axes) [m].

    Args:
        robot: the model.
        frame: a frame name (default: the first end effector).
        lower, upper: the box corners (3,) [m], -inf / +inf for an open side.
        band: activation band [m] > 0, below half of each finite side.
        gain: reference gain [1/s].
        shape: activation shape, "cosine" or "step".
        name: the name results report (default ``frame_box(<frame>)``).
    """

    type_name = "frame_box"
    unit = "position [m]"

    def row_names(self) -> list[str]:
        return ["x", "y", "z"]

    def __init__(self, robot: Robot, frame: str | None = None, lower: Sequence[float] = (-np.inf,) * 3,
                 upper: Sequence[float] = (np.inf,) * 3, band: float = 0.1, gain: float = 1.0,
                 shape: str = "cosine", name: str | None = None) -> None:
        self.frame = frame or robot.ee_frames[0]
        self.name = name or f"frame_box({self.frame})"
        self.frame_id = robot.frame_id(frame)
        box = [np.asarray(corner, dtype=float) for corner in (lower, upper)]
        if any(corner.shape != (3,) for corner in box):
            raise ObjectiveError(f"{self.name}: lower and upper must be 3 numbers [m] each, got {lower!r}, {upper!r}")
        self._set_valid_set(box[0], box[1], finite_number(band, f"{self.name}: band", positive=True), gain, shape)

    def value(self, state: Configuration) -> np.ndarray:
        return state.pose(self.frame_id).translation.copy()

    def jacobian(self, state: Configuration) -> np.ndarray:
        return state.jacobian(self.frame_id)[:3]
