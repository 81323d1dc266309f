"""Frame conventions: ROS (world ENU, body FLU) inside, Fossen (NED, FRD) at the edges.

Models and Pinocchio stay in REP-103 form. Marine users read and write the
vehicle state as Fossen's ``eta`` = [x, y, z, phi, theta, psi] (position in
NED, ZYX Euler angles of the FRD body frame) and ``nu`` = [u, v, w, p, q, r]
(body FRD twist). Planar systems use eta = [x, y, psi] and nu = [u, v, r].
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

#: Rotation from ENU world axes to NED world axes (a swap of x and y, z flipped).
R_NED_ENU = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
#: Rotation from FRD body axes to FLU body axes (y and z flipped); its own inverse.
R_FLU_FRD = np.diag([1.0, -1.0, -1.0])

AXIS_NAMES = ("x", "y", "z", "roll", "pitch", "yaw")


def pose_from_xyzrpy(values: np.ndarray) -> pin.SE3:
    """SE(3) pose from [x, y, z, roll, pitch, yaw] [m, rad] with R = Rz(yaw) Ry(pitch) Rx(roll)."""
    return pin.SE3(pin.rpy.rpyToMatrix(*values[3:6]), np.asarray(values[:3], dtype=float))


def pose_from_xyyaw(values: np.ndarray) -> pin.SE3:
    """SE(3) pose in the x-y plane from [x, y, yaw] [m, m, rad]."""
    return pin.SE3(pin.rpy.rpyToMatrix(0.0, 0.0, float(values[2])), np.array([values[0], values[1], 0.0]))


def wrap_angle(angle: float) -> float:
    """Angle wrapped to [-pi, pi) [rad]."""
    return float(wrap_angles(angle))


def wrap_angles(angles: np.ndarray) -> np.ndarray:
    """Angles wrapped to [-pi, pi) [rad], entry by entry (the numbers of :func:`wrap_angle`)."""
    return (angles + np.pi) % (2.0 * np.pi) - np.pi


def eta_from_pose(pose_enu_flu: pin.SE3, planar: bool) -> np.ndarray:
    """Fossen's eta of a body pose given in ENU world / FLU body axes.

    Returns:
        [x, y, z, phi, theta, psi] in NED (6,), or [x, y, psi] (3,) when ``planar``.
    """
    position = R_NED_ENU @ pose_enu_flu.translation
    rotation = R_NED_ENU @ pose_enu_flu.rotation @ R_FLU_FRD
    angles = pin.rpy.matrixToRpy(rotation)
    if planar:
        return np.array([position[0], position[1], angles[2]])
    return np.concatenate([position, angles])


def pose_from_eta(eta: np.ndarray) -> pin.SE3:
    """The ENU/FLU pose of a body whose Fossen eta (6,) or planar eta (3,) is given."""
    eta = np.asarray(eta, dtype=float)
    if eta.size == 3:
        eta = np.array([eta[0], eta[1], 0.0, 0.0, 0.0, eta[2]])
    rotation_ned_frd = pin.rpy.rpyToMatrix(*eta[3:6])
    rotation = R_NED_ENU.T @ rotation_ned_frd @ R_FLU_FRD.T
    return pin.SE3(rotation, R_NED_ENU.T @ eta[:3])


def nu_from_twist(twist_flu: np.ndarray) -> np.ndarray:
    """Fossen's nu from a body twist in FLU axes.

    Args:
        twist_flu: [vx, vy, vz, wx, wy, wz] (6,) or planar [vx, vy, wz] (3,), local FLU axes.

    Returns:
        [u, v, w, p, q, r] (6,) or [u, v, r] (3,), FRD axes.
    """
    twist_flu = np.asarray(twist_flu, dtype=float)
    if twist_flu.size == 3:
        return twist_flu * np.array([1.0, -1.0, -1.0])
    return np.concatenate([R_FLU_FRD @ twist_flu[:3], R_FLU_FRD @ twist_flu[3:6]])


def twist_from_nu(nu: np.ndarray) -> np.ndarray:
    """Body twist in FLU axes from Fossen's nu (the inverse of :func:`nu_from_twist`)."""
    return nu_from_twist(nu)  # the FRD <-> FLU flip is an involution
