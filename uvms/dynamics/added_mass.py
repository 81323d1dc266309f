"""The hydrodynamic links of a UVMS on its Pinocchio model, and what their added mass adds to the dynamics.

A link with Fossen parameters (:mod:`uvms.dynamics.hydro_parameters`) is placed on the model by
:func:`resolve_links`. Its added mass M_A enters the equations of motion twice (derivation: the docstring
of :mod:`uvms.dynamics.plant`): in the mass matrix, Mbar = M + sum_l J_l^T M_A,l J_l
(:func:`augmented_mass_matrix`), and as the Coriolis term C_A(nu) nu (formed with the other wrenches of a link in
:mod:`uvms.numerics._kernels.hydro`). With no current, damping or gravity the added-mass-augmented momentum is
conserved; :func:`generalized_jacobian_added_mass` is the generalized Jacobian of that momentum.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..errors import UVMSError
from .hydrodynamics import HydroParameters, LinkHydrodynamics, hydrodynamics_of
from ..robot.robot import Robot
from ..robot.kinematics import generalized_jacobian_from_parts, mass_matrix_split


LOCAL = pin.ReferenceFrame.LOCAL


@dataclass(frozen=True)
class HydroLink:
    """A link with hydrodynamic parameters, placed on the Pinocchio model."""

    name: str
    frame_id: int
    joint_id: int
    placement: pin.SE3  # link frame in its parent joint's frame
    params: LinkHydrodynamics


def resolve_links(model: pin.Model, hydro: HydroParameters) -> list[HydroLink]:
    """The links of ``hydro`` as (frame, joint, placement) of ``model``.

    Raises:
        NameNotFound: a link the model does not have.
    """
    hydro.check_links(frame.name for frame in model.frames if frame.type == pin.FrameType.BODY)
    links = []
    for name, params in hydro.links.items():
        frame_id = model.getFrameId(name, pin.FrameType.BODY)
        frame = model.frames[frame_id]
        links.append(HydroLink(name, frame_id, frame.parentJoint, frame.placement.copy(), params))
    return links


def augmented_mass_matrix(model: pin.Model, data: pin.Data, links: list[HydroLink], q: np.ndarray) -> np.ndarray:
    """Mbar = M + sum_l J_l^T M_A,l J_l (nv, nv): the rigid mass matrix with the links' added mass."""
    matrix = pin.crba(model, data, q)
    matrix = np.triu(matrix) + np.triu(matrix, 1).T  # crba may fill only the upper triangle
    if links:
        pin.computeJointJacobians(model, data, q)
        for link in links:
            jacobian = pin.getFrameJacobian(model, data, link.frame_id, LOCAL)
            matrix += jacobian.T @ link.params.added_mass @ jacobian
    return matrix


def generalized_jacobian_added_mass(
    robot: Robot, hydro: HydroParameters | None, q: np.ndarray, frame: str | None = None
) -> np.ndarray:
    """Generalized Jacobian (6, n_arm) at zero *added-mass-augmented* momentum.

    GJM_A = J_m - J_b Mbar_bb^-1 Mbar_bm with Mbar = M + sum_l J_l^T M_A,l J_l; it maps
    the arm rates to the world-aligned end-effector twist of a free-floating UVMS
    in a still, inviscid fluid at rest (no damping, no current, no restoring
    forces). With M_A = 0 it equals ``robot.generalized_jacobian``.

    Args:
        robot: a floating- or planar-base Robot.
        hydro: the parameters (None: the model's own, see :func:`uvms.dynamics.hydrodynamics.hydrodynamics_of`).
        q: configuration (nq,).
        frame: end-effector frame (default: the first).

    Raises:
        UVMSError: fixed base; invalid parameters or link names.
    """
    if robot.base_type == "fixed":
        raise UVMSError(f"{robot.name} has a fixed base: there is no free-floating base to conserve momentum")
    q = robot.check_configuration(q)
    hydro = hydrodynamics_of(robot, required=False) if hydro is None else hydro
    mass = augmented_mass_matrix(robot.model, robot.data, resolve_links(robot.model, hydro), q)
    return generalized_jacobian_from_parts(robot.jacobian(q, frame), *mass_matrix_split(mass, robot.n_vehicle),
                                           robot.n_vehicle)
