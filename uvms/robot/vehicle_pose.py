"""The vehicle of a Robot: its pose in the world (ENU) and Fossen's eta (NED) / nu (FRD) (a mixin of `uvms.Robot`).

The model stays in ROS form (world ENU, body FLU); the Fossen accessors convert at the edge with
``uvms.robot.conventions``: eta = [x, y, z, phi, theta, psi] (NED) and nu = [u, v, w, p, q, r] (body FRD), or
[x, y, psi] and [u, v, r] for a planar vehicle.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ..errors import ConfigurationError, NoVehicleError
from . import conventions


class VehicleAccessors:
    """Vehicle pose and eta/nu accessors; the class using it provides the Robot interface (model, base_type, checks)."""

    def _vehicle_q(self, base: np.ndarray | pin.SE3) -> np.ndarray:
        if self.base_type == "fixed":
            raise ConfigurationError(f"{self.name} has a fixed base ({self.base_reason}): give only arm values, or "
                                     "load the model with base='floating' or 'planar' to give a vehicle pose")
        if isinstance(base, pin.SE3):
            pose = base
        else:
            size = 3 if self.base_type == "planar" else 6
            values = self.check_velocity(base, size, f"{self.base_type} base pose")
            pose = conventions.pose_from_xyyaw(values) if size == 3 else conventions.pose_from_xyzrpy(values)
        joint_motion = self.model.jointPlacements[1].actInv(pose)
        if self.base_type == "floating":
            return pin.SE3ToXYZQUAT(joint_motion)
        rotation, translation = joint_motion.rotation, joint_motion.translation
        if abs(translation[2]) > 1e-9 or not np.allclose(rotation[2], [0.0, 0.0, 1.0], atol=1e-9):
            raise ConfigurationError("a planar base pose must lie in the x-y plane of the planar joint")
        return np.array([translation[0], translation[1], rotation[0, 0], rotation[1, 0]])

    @property
    def base_placement(self) -> pin.SE3:
        """joint_M_base: the vehicle's root link frame in its vehicle joint's frame (identity unless the URDF places
        the link away from its joint); ``base_pose(q) * base_placement`` is the root link's pose in the world."""
        return self.model.frames[self.model.getFrameId(self.root_link)].placement.copy()

    def base_pose(self, q: np.ndarray, check: bool = True) -> pin.SE3:
        """Pose of the vehicle body in the world, ``transform_base_to_world`` (identity for a fixed base).

        Args:
            q: configuration (nq,); checked unless ``check=False`` (the rows of a run, checked once as a whole).
        """
        if check:
            q = self.check_configuration(q)
        if self.base_type == "fixed":
            return pin.SE3.Identity()
        if self.base_type == "floating":
            joint_motion = pin.XYZQUATToSE3(q[:7])
        else:
            yaw = np.arctan2(q[3], q[2])
            joint_motion = pin.SE3(pin.rpy.rpyToMatrix(0.0, 0.0, yaw), np.array([q[0], q[1], 0.0]))
        return self.model.jointPlacements[1] * joint_motion

    def base_values(self, q: np.ndarray, check: bool = True) -> np.ndarray:
        """The vehicle pose of q as users write it (``base.pose_names``): [x, y, yaw] (planar) or
        [x, y, z, roll, pitch, yaw] (floating) [m, rad], world ENU, R = Rz(yaw) Ry(pitch) Rx(roll); (0,) if fixed.

        The inverse of ``configuration(base=...)``; angles in [-pi, pi]. ``check=False`` skips the check of q.
        """
        if check:
            q = self.check_configuration(q)
        return self.base_values_rows(np.asarray(q)[np.newaxis])[0]

    def base_values_rows(self, q_rows: np.ndarray) -> np.ndarray:
        """:meth:`base_values` of each row of q (N, nq), checked by the caller (a run's rows): (N, n_vehicle), (N, 0)
        if fixed. The numbers of :meth:`base_pose` and ``matrixToRpy`` row by row, with Pinocchio's functions and
        the vehicle joint's placement looked up once (~3-6 us a row; ~12 us through :meth:`base_values`)."""
        count = len(q_rows)
        if self.base_type == "fixed":
            return np.zeros((count, 0))
        placement, to_rpy = self.model.jointPlacements[1], pin.rpy.matrixToRpy
        if self.base_type == "floating":
            rows, to_pose = np.empty((count, 6)), pin.XYZQUATToSE3
            for row, q in enumerate(q_rows):
                pose = placement * to_pose(q[:7])
                rows[row, :3], rows[row, 3:] = pose.translation, to_rpy(pose.rotation)
            return rows
        rows, se3, rotation_z, arctan2 = np.empty((count, 3)), pin.SE3, pin.rpy.rpyToMatrix, np.arctan2
        for row, q in enumerate(q_rows):
            pose = placement * se3(rotation_z(0.0, 0.0, arctan2(q[3], q[2])), np.array([q[0], q[1], 0.0]))
            rows[row, :2], rows[row, 2] = pose.translation[:2], to_rpy(pose.rotation)[2]
        return rows

    # ------------------------------------------------------ Fossen accessors

    def eta_ned(self, q: np.ndarray) -> np.ndarray:
        """Fossen eta of the vehicle: [x, y, z, phi, theta, psi] NED (6,) or [x, y, psi] (3,) planar [m, rad]."""
        self._require_vehicle()
        return conventions.eta_from_pose(self.base_pose(q), planar=self.base_type == "planar")

    def nu_frd(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Fossen nu of the vehicle: [u, v, w, p, q, r] body FRD (6,) or [u, v, r] (3,) planar [m/s, rad/s]."""
        self._require_vehicle()
        self.check_configuration(q)
        v = self.check_velocity(v)
        return conventions.nu_from_twist(v[: self.n_vehicle])

    def configuration_from_eta(self, eta: np.ndarray, arm: np.ndarray | None = None) -> np.ndarray:
        """q (nq,) from Fossen's eta (NED) and arm joint values: the inverse of :meth:`eta_ned`."""
        self._require_vehicle()
        eta = self.check_velocity(eta, self.n_vehicle, "eta")
        return self.configuration(base=conventions.pose_from_eta(eta), arm=arm)

    def velocity_from_nu(self, nu: np.ndarray, arm_velocity: np.ndarray | None = None) -> np.ndarray:
        """v (nv,) from Fossen's nu (body FRD) and arm velocities: the inverse of :meth:`nu_frd`."""
        self._require_vehicle()
        nu = self.check_velocity(nu, self.n_vehicle, "nu")
        arm = (np.zeros(self.n_arm) if arm_velocity is None
               else self.check_velocity(arm_velocity, self.n_arm, "arm velocity"))
        return np.concatenate([conventions.twist_from_nu(nu), arm])

    def _require_vehicle(self, what: str = "a vehicle state (eta, nu)") -> None:
        """Raise NoVehicleError for a fixed base, naming what was asked and how to get a vehicle."""
        if self.base_type == "fixed":
            raise NoVehicleError(
                f"{self.name} has a fixed base ({self.base_reason}): there is no vehicle, so no {what}; "
                f"use robot.jacobian(q, frame) for the arm, or load the model with base='floating' or 'planar'")
