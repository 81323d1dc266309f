"""Robot: a Pinocchio model seen as a vehicle (floating, planar or fixed base) plus arms."""

from __future__ import annotations

import functools
import math
import os
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import pinocchio as pin

from ..errors import ConfigurationError, FrameNotFound, JointNotFound, NameNotFound, NotARobot, UVMSError
from ..io import outputs
from ..numerics.validate import finite_array
from . import kinematics, urdf_export
from .bases import BASE_TYPES, BaseType
from .state import KinematicState
from .structure import (
    EE_GIVEN,
    JointClass,
    JointInfo,
    base_type_of,
    default_end_effectors,
    joint_class_table,
    joint_infos,
    unit_norm_slices,
)
from .vehicle_pose import VehicleAccessors

FLOAT64 = np.dtype(np.float64)  #: the float vectors' dtype the checks pass as they are (numpy's float64: one object)
#: Default task axes by base type (the facts live in `uvms.robot.bases`).
DEFAULT_AXES = {name: base.task_axes for name, base in BASE_TYPES.items()}


class Robot(VehicleAccessors):
    """A UVMS model: Pinocchio ``model``/``data``, the vehicle/arm split and end-effector frames.

    Configuration q = [vehicle (7 floating, 4 planar, 0 fixed), arm...] and velocity v = [vehicle twist in its local
    axes (6 or 3), arm...], exactly Pinocchio's. Poses are in the model's world frame (ENU, z up).

    Attributes:
        model: the Pinocchio model.
        data: the work data of :meth:`fk`, :meth:`jacobian` and the like (shared by every call: not thread-safe).
        base: the kind of vehicle base and its facts (`uvms.robot.bases.BaseType`); base_type: its name,
            "floating", "planar" or "fixed".
        base_reason: why the base is what it is, one line (`uvms.load`'s rule), e.g. "floating (added: the
            root link 'hull' carries 1810 kg; base='fixed' to hold it)".
        ee_frames: names of the end-effector frames; the first is the default. ee_reason: the rule that chose
            them, one line (:func:`.structure.default_end_effectors`), or ``EE_GIVEN``.
        joint_classes: {joint name: :class:`.structure.JointClass`} (read-only) of every non-vehicle joint of the
            model file that is not fixed there: arm joints, mimics, and the joints uvms froze (propellers,
            sensors, fixed by range, left out of ``arm_joints=``), each with the reason (``uvms.load``).
        name: model name; source: file it came from (or "<string>").
        urdf: the URDF text Pinocchio built the model from: the file's, with the frozen joints written as fixed
            joints and mimic chains composed (`uvms.load`), or composed by `uvms.model.mount_arm` for a mounted
            arm; None when the Robot was built from a Pinocchio model alone. A base joint that uvms added is not
            in it: :meth:`save_urdf` writes it. packages: the ROS packages its meshes resolve through, {name: folder}.
    """

    def __init__(self, model: pin.Model, *, ee: str | Sequence[str] | None = None, name: str | None = None,
                 source: str = "<model>", urdf: str | None = None, base_reason: str | None = None,
                 packages: Mapping[str, Path] | None = None,
                 joint_classes: Mapping[str, JointClass] | None = None) -> None:
        self.model = model
        self._state = KinematicState(model)  # what fk and jacobian read
        self.data = self._state.data
        self.name = name or model.name
        self.source = source
        self.urdf = urdf
        self.packages = dict(packages or {})
        self.base: BaseType = BASE_TYPES[base_type_of(model)]
        self.base_type = self.base.name
        self.base_reason = base_reason or (
            f"{self.base_type} (the model's root joint {model.names[1]!r})" if self.base_type != "fixed"
            else "fixed (the model has no vehicle joint)")
        self.n_vehicle = self.base.nv
        self.nq_vehicle = self.base.nq
        self.frame_names = [frame.name for frame in model.frames]
        if ee is None:
            self.ee_frames, self.ee_reason = default_end_effectors(model)
        else:
            self.ee_frames, self.ee_reason = [ee] if isinstance(ee, str) else list(ee), EE_GIVEN
        self.ee_frame_ids = [self.frame_id(frame) for frame in self.ee_frames]
        self.joint_classes = joint_class_table(model, joint_classes)
        self.joints = joint_infos(model)
        self._unit_slices = unit_norm_slices(self.joints)
        # where the arm's values sit in q when no arm joint is continuous (angle = atan2 of a (cos, sin) pair)
        self._arm_q_index = (np.concatenate([np.arange(j.idx_q, j.idx_q + j.nq) for j in self.arm_joints]).astype(int)
                             if all(j.nq == j.nv for j in self.arm_joints) and self.arm_joints else None)

    # ----------------------------------------------------------------- sizes
    @property
    def nq(self) -> int:
        """Size of a configuration q."""
        return self.model.nq

    @property
    def nv(self) -> int:
        """Size of a velocity v (vehicle DOF + arm DOF)."""
        return self.model.nv

    @property
    def n_arm(self) -> int:
        """Number of arm (non-vehicle) velocity entries."""
        return self.model.nv - self.n_vehicle

    @property
    def arm_joints(self) -> list[JointInfo]:
        """The joints a user commands: not the vehicle's, not mimics (which have no entry in q and v)."""
        return [joint for joint in self.joints if not joint.is_vehicle and joint.nv > 0]

    @property
    def arm_joint_names(self) -> list[str]:
        """Names of the arm joints, in the order of q and v (n_arm of them: every arm joint has one velocity)."""
        return [joint.name for joint in self.arm_joints]

    @property
    def mimic_joint_names(self) -> list[str]:
        """Names of the mimic joints of the model: they follow an arm joint (``joint_classes`` says which)."""
        return [joint.name for joint in self.joints if not joint.is_vehicle and joint.nv == 0]

    @property
    def arm_limits(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper limits of the arm joint values (n_arm,) [rad or m]; +-inf when unbounded."""
        lower, upper = [], []
        for joint in self.arm_joints:
            if joint.nq == joint.nv:
                lower.extend(joint.lower)
                upper.extend(joint.upper)
            else:  # continuous joint stored as (cos, sin)
                lower.extend([-np.inf] * joint.nv)
                upper.extend([np.inf] * joint.nv)
        return np.array(lower), np.array(upper)

    @property
    def total_mass(self) -> float:
        """Total mass [kg] of every link, the root link of a fixed base included.

        (Pinocchio holds a fixed root link's inertia on the universe, ``model.inertias[0]``, which
        ``pin.computeTotalMass`` leaves out.)
        """
        return float(sum(inertia.mass for inertia in self.model.inertias))

    @functools.cached_property
    def root_link(self) -> str:
        """The vehicle's link: the one its floating/planar joint carries; for a fixed base, the model's root link
        (found once: a search of every frame, which the actuated chain's step asked for several times)."""
        joint = 0 if self.base_type == "fixed" else 1
        bodies = [f.name for f in self.model.frames if f.type == pin.FrameType.BODY and f.parentJoint == joint]
        return bodies[0] if bodies else self.model.frames[0].name

    # ----------------------------------------------------------------- names
    def frame_id(self, frame: str | None = None) -> int:
        """Index of a frame; None means the first end effector.

        Raises:
            FrameNotFound: unknown name (the message lists the close names).
        """
        if frame is None:
            return self.ee_frame_ids[0]
        if not isinstance(frame, str) or not self.model.existFrame(frame):
            raise FrameNotFound(str(frame), self.frame_names)
        return self.model.getFrameId(frame)

    def joint_id(self, joint: str) -> int:
        """Index of a joint. Raises JointNotFound with the close names."""
        if not self.model.existJointName(joint):
            raise JointNotFound(joint, list(self.model.names)[1:])
        return self.model.getJointId(joint)

    def joint(self, name: str) -> JointInfo:
        """The joint called ``name`` (sizes, indices in q and v, limits). Raises JointNotFound."""
        return self.joints[self.joint_id(name) - 1]

    @functools.cached_property
    def urdf_root(self) -> ET.Element | None:
        """The ``<robot>`` element of the model's URDF, parsed once (None when the robot has no URDF)."""
        return ET.fromstring(self.urdf) if self.urdf else None

    def save_urdf(self, path: str | os.PathLike) -> Path:
        """Write the model as a URDF file (atomically) that ``uvms.load`` reads back as the same model, and return
        its path: the base stated and meshes by absolute path (:func:`.urdf_export.self_describing_urdf`).

        Raises:
            UVMSError: the Robot has no URDF (built from a Pinocchio model alone), or the file cannot be written.
        """
        if self.urdf is None:
            raise UVMSError(f"{self.name} has no URDF (it was built from a Pinocchio model); load it from a file "
                            "or compose it with uvms.model.mount_arm to save it")
        vehicle_joint = self.model.names[1] if self.base_type != "fixed" else None
        text = urdf_export.self_describing_urdf(self.urdf, self.base_type, vehicle_joint, self.source)
        outputs.write_text(path, text)
        return Path(path)

    # ------------------------------------------------------- configurations
    def check_configuration(self, q: np.ndarray) -> np.ndarray:
        """q as a float array, after checking its size, finiteness and unit rotation parts.

        Raises:
            ConfigurationError: wrong size, NaN/inf, or a non-unit quaternion / (cos, sin) pair.
        """
        return self._check_vector(q, self.nq, "configuration q", check_manifold=True)

    def check_velocity(self, v: np.ndarray, size: int | None = None, what: str = "velocity v") -> np.ndarray:
        """v as a float array, after checking its size (default nv) and finiteness."""
        return self._check_vector(v, self.nv if size is None else size, what)

    def check_configurations(self, q: np.ndarray) -> np.ndarray:
        """Configurations (N, nq) as a float array, each row checked as :meth:`check_configuration` does, at once.

        Raises:
            ConfigurationError: wrong shape, NaN/inf, or a non-unit rotation part (the first row that has one).
        """
        array = finite_array(q, "configurations q", (None, self.nq), error=ConfigurationError)
        for joint_name, part in self._unit_slices:
            norms = np.linalg.norm(array[:, part], axis=1)
            bad = np.flatnonzero(np.abs(norms - 1.0) > 1e-6)
            if bad.size:
                self._refuse_rotation_part(f"configuration q of row {bad[0]}", joint_name, float(norms[bad[0]]))
        return array

    def _check_vector(self, vector: np.ndarray, size: int, what: str, check_manifold: bool = False) -> np.ndarray:
        # the common case, a float vector of the size, is read once as Python floats; anything else is converted
        common = type(vector) is np.ndarray and vector.dtype is FLOAT64 and vector.shape == (size,)
        values = vector.tolist() if common else None
        if values is None or not all(map(math.isfinite, values)):
            vector = finite_array(vector, what, (size,), error=ConfigurationError)  # (raises where not finite)
            values = vector.tolist()
        for joint_name, part in self._unit_slices if check_manifold else ():
            norm = math.hypot(*values[part])  # a threshold on the floats read (no numpy call per part)
            if abs(norm - 1.0) > 1e-6:
                self._refuse_rotation_part(what, joint_name, norm)
        return vector

    @staticmethod
    def _refuse_rotation_part(what: str, joint_name: str, norm: float) -> None:
        raise ConfigurationError(f"{what}: the rotation part of joint {joint_name!r} has norm {norm:.6g}; it must be a "
                                 f"unit quaternion / (cos, sin) pair — build q with robot.configuration()")

    def neutral(self) -> np.ndarray:
        """The neutral configuration (vehicle at the origin, arm joints at zero)."""
        return pin.neutral(self.model)

    def random_configuration(self, rng: np.random.Generator | int | None = None,
                             position_range: float = 1.0) -> np.ndarray:
        """A configuration with arm joints uniform inside their limits; ``rng``: a numpy Generator or seed; the
        vehicle's position uniform in [-position_range, position_range] per axis [m], its attitude on SO(3)
        (floating) or in yaw (planar)."""
        rng = np.random.default_rng(rng)
        lower, upper = self.arm_limits
        lower = np.where(np.isfinite(lower), lower, -np.pi)
        upper = np.where(np.isfinite(upper), upper, np.pi)
        arm = rng.uniform(lower, upper)
        if self.base_type == "floating":
            quaternion = rng.normal(size=4)
            rotation = pin.Quaternion(*(quaternion / np.linalg.norm(quaternion))).toRotationMatrix()
            base = pin.SE3(rotation, rng.uniform(-position_range, position_range, 3))
        elif self.base_type == "planar":
            base = np.array([*rng.uniform(-position_range, position_range, 2), rng.uniform(-np.pi, np.pi)])
        else:
            base = None
        return self.configuration(base=base, arm=arm)

    def configuration(self, base: np.ndarray | pin.SE3 | None = None,
                      arm: np.ndarray | Mapping[str, float] | None = None) -> np.ndarray:
        """q (nq,) from a vehicle pose and arm joint values.

        Args:
            base: pose of the vehicle body in the world [m, rad]: [x, y, psi] (planar), [x, y, z, roll, pitch, yaw]
                with R = Rz(yaw) Ry(pitch) Rx(roll) (floating), or a ``pin.SE3``; None: at the origin.
            arm: arm joint values (n_arm,) [rad or m], or a table {arm joint: value} whose joints left out are at
                0; None: zeros.

        Raises:
            NameNotFound: a table naming a joint that is not an arm joint; ConfigurationError: bad values.
        """
        q = self.neutral()
        if base is not None:
            q[: self.nq_vehicle] = self._vehicle_q(base)
        if isinstance(arm, Mapping):
            unknown = [joint for joint in arm if joint not in self.arm_joint_names]
            if unknown:
                raise NameNotFound("arm joint", str(unknown[0]), self.arm_joint_names)
            arm = [arm.get(joint, 0.0) for joint in self.arm_joint_names]
        if arm is not None:
            arm = self.check_velocity(arm, self.n_arm, "arm joint values")
            for joint in self.arm_joints:
                values = arm[joint.idx_v - self.n_vehicle: joint.idx_v - self.n_vehicle + joint.nv]
                if joint.nq == joint.nv:
                    q[joint.idx_q: joint.idx_q + joint.nq] = values
                else:  # continuous joint: angle -> (cos, sin)
                    q[joint.idx_q: joint.idx_q + 2] = [np.cos(values[0]), np.sin(values[0])]
        return q

    def arm_configuration(self, q: np.ndarray) -> np.ndarray:
        """Arm joint values (n_arm,) [rad or m] of a configuration (angles for continuous joints)."""
        return self.arm_values(self.check_configuration(q))

    def arm_values(self, q: np.ndarray) -> np.ndarray:
        """:meth:`arm_configuration` of a q already checked (e.g. from ``pin.integrate``): no validation; q (nq,) ->
        (n_arm,), or rows (N, nq) -> (N, n_arm)."""
        if self._arm_q_index is not None:
            return q[..., self._arm_q_index]
        if np.ndim(q) == 2:
            return np.array([self.arm_values(row) for row in q]).reshape(len(q), self.n_arm)
        values = []
        for joint in self.arm_joints:
            part = q[joint.idx_q: joint.idx_q + joint.nq]
            values.extend(part if joint.nq == joint.nv else [np.arctan2(part[1], part[0])])
        return np.array(values)

    # ------------------------------------------------------------ kinematics
    # fk, jacobian and the like: conveniences by frame name over the robot's own KinematicState (its ``data``),
    # one q per call; library code keeps a Configuration of its own and updates it
    def _at(self, q: np.ndarray) -> KinematicState:
        self._state.update(self.check_configuration(q))
        return self._state

    def fk(self, q: np.ndarray, frame: str | None = None) -> pin.SE3:
        """Pose of a frame in the world, ``transform_frame_to_world`` (default: first end effector), a copy."""
        return self._at(q).pose(self.frame_id(frame)).copy()

    def jacobian(self, q: np.ndarray, frame: str | None = None) -> np.ndarray:
        """World-aligned Jacobian (6, nv): [v_origin; omega] in world axes = J v, a copy."""
        return self._at(q).jacobian(self.frame_id(frame)).copy()

    def generalized_jacobian(self, q: np.ndarray, frame: str | None = None) -> np.ndarray:
        """Generalized Jacobian (6, n_arm) of a free-floating base at zero momentum.

        twist_ee (world-aligned) = GJM @ qdot_arm when the vehicle is passive and the system momentum is zero.

        Raises:
            NoVehicleError: a fixed base has no vehicle: use :meth:`jacobian`.
        """
        self._require_vehicle("generalized Jacobian (it needs a free-floating vehicle whose momentum is conserved)")
        state = self._at(q)
        a_base, a_arm = state.centroidal_rows(self.base_type, self.n_vehicle)
        return kinematics.generalized_jacobian_from_parts(state.jacobian(self.frame_id(frame)), a_base, a_arm,
                                                          self.n_vehicle)

    def base_velocity(self, q: np.ndarray, arm_velocity: np.ndarray, momentum: np.ndarray | None = None) -> np.ndarray:
        """Vehicle velocity implied by momentum conservation (n_vehicle,), local axes as in v.

        Args:
            q: configuration (nq,).
            arm_velocity: arm joint velocities (n_arm,).
            momentum: centroidal momentum h [N s; N m s] in world axes (6,) or
                its planar rows [hx, hy, kz] (3,); None means zero.

        Raises:
            NoVehicleError: a fixed base has no vehicle.
        """
        self._require_vehicle("vehicle velocity from momentum")
        state = self._at(q)
        arm_velocity = self.check_velocity(arm_velocity, self.n_arm, "arm velocity")
        if momentum is not None:
            momentum = self.check_velocity(momentum, len(kinematics.CONSERVED_MOMENTUM_ROWS[self.base_type]),
                                           "momentum")
        a_base, a_arm = state.centroidal_rows(self.base_type, self.n_vehicle)
        return kinematics.base_velocity_from_momentum(a_base, a_arm, arm_velocity, momentum)

    def free_floating_velocity(self, q: np.ndarray, arm_velocity: np.ndarray,
                               momentum: np.ndarray | None = None) -> np.ndarray:
        """Full velocity v (nv,) of the free-floating system: base from momentum, arm as given."""
        return np.concatenate([self.base_velocity(q, arm_velocity, momentum), arm_velocity])

    def manipulability(self, q: np.ndarray, frame: str | None = None, axes: Sequence[str] | None = None) -> float:
        """Yoshikawa manipulability sqrt(det(J J^T)) over the task ``axes``.

        ``axes`` defaults to all six for spatial bases and (x, y, yaw) for planar ones.
        """
        return kinematics.manipulability_of(self.jacobian(q, frame)[kinematics.axis_rows(axes or self.base.task_axes)])

    def generalized_manipulability(self, q: np.ndarray, frame: str | None = None,
                                   axes: Sequence[str] | None = None) -> float:
        """Manipulability of the generalized Jacobian (free-floating base), same ``axes`` rule."""
        rows = kinematics.axis_rows(axes or self.base.task_axes)
        return kinematics.manipulability_of(self.generalized_jacobian(q, frame)[rows])

    def __repr__(self) -> str:
        return (f"Robot({self.name!r}, base={self.base_type}, nq={self.nq}, nv={self.nv}, "
                f"n_arm={self.n_arm}, ee={self.ee_frames})")


def check_robot(robot: object, where: str) -> Robot:
    """``robot`` if it is a :class:`Robot`; else NotARobot saying what came instead and how to get one.

    Args:
        robot: what the caller passed as the model; where: the function or class that needs it (for the message).
    """
    if not isinstance(robot, Robot):
        shown = repr(robot)
        shown = shown if len(shown) <= 60 else shown[:57] + "..."
        hint = f": uvms.load({shown}) loads that model" if isinstance(robot, (str, os.PathLike)) else ""
        raise NotARobot(f"{where} needs a uvms.Robot (what uvms.load returns), got {type(robot).__name__} {shown}"
                        f"{hint}")
    return robot
