"""The hydrodynamic links of a UVMS on its Pinocchio model, and what their added mass adds to the dynamics.

A link with Fossen parameters (:mod:`uvms.dynamics.hydro.parameters`) is placed on the model by
:func:`resolve_links`. Its added mass M_A enters the equations of motion twice (derivation: the docstring
of :mod:`uvms.dynamics.plant.plant`): in the mass matrix, Mbar = M + sum_l J_l^T M_A,l J_l
(:func:`augmented_mass_matrix`), and as the Coriolis term C_A(nu) nu (formed with the other wrenches of a link in
:mod:`uvms.numerics._kernels.hydro`, from the links' constants stacked in :class:`StackedLinks`). With no current,
damping or gravity the added-mass-augmented momentum is conserved; :func:`generalized_jacobian_added_mass` is the
generalized Jacobian of that momentum.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ...errors import UVMSError
from ...robot.configuration import Configuration
from ...robot.kinematics import generalized_jacobian_from_parts, mass_matrix_split
from ...robot.robot import Robot
from ..hydro.hydrodynamics import HydroParameters, LinkHydrodynamics, hydrodynamics_of

LOCAL = pin.ReferenceFrame.LOCAL


@dataclass(frozen=True)
class HydroLink:
    """A link with hydrodynamic parameters, placed on the Pinocchio model."""

    name: str
    frame_id: int
    joint_id: int
    placement: pin.SE3  # link frame in its parent joint's frame
    params: LinkHydrodynamics


@dataclass(frozen=True)
class LinkStates:
    """The hydrodynamic links at one (q, v), stacked (L links).

    Attributes:
        twists: nu_l (L, 6) body twists [m/s, rad/s] in the link frames; relative: nu_r,l = nu_l - [R_l^T v_c; 0].
        rotations: (L, 3, 3) link to world; positions: (L, 3) the link frames' origins in the world [m].
    """

    twists: np.ndarray
    relative: np.ndarray
    rotations: np.ndarray
    positions: np.ndarray


@dataclass(frozen=True)
class StackedLinks:
    """The hydrodynamic links' constants as arrays over the links (L of them), for one numpy pass per evaluation.

    Attributes:
        frames, joints: (L,) the links' frame ids and their parent joints.
        motion_to_link: (L, 6, 6) the action of the inverse placement: a motion of the joint in the link frame.
        rotations: (L, 3, 3) the links' rotations in their joints' frames; translations: (L, 3) their origins there.
        added_mass: (L, 6, 6); linear_damping, forward_damping, quadratic_damping: (L, 6) d_l, d_f, d_q (link
            frames, FLU; :meth:`uvms.dynamics.hydro.parameters.LinkHydrodynamics.damping_wrench`).
        buoyancy: (L,) rho g V [N] (0 without gravity); center_of_buoyancy: (L, 3) [m] in the link frames.
        buoyant: whether any link has a volume.
    """

    frames: tuple[int, ...]
    joints: tuple[int, ...]
    motion_to_link: np.ndarray
    rotations: np.ndarray
    translations: np.ndarray
    added_mass: np.ndarray
    linear_damping: np.ndarray
    forward_damping: np.ndarray
    quadratic_damping: np.ndarray
    buoyancy: np.ndarray
    center_of_buoyancy: np.ndarray
    buoyant: bool

    @property
    def count(self) -> int:
        """The number of links L."""
        return len(self.frames)

    def damping_wrenches(self, relative: np.ndarray) -> np.ndarray:
        """The links' damping wrenches (..., L, 6) [N, N m] at their relative twists nu_r (..., L, 6) (L links, any
        leading axes: rows of a run): the stacked form of
        :meth:`uvms.dynamics.hydro.parameters.LinkHydrodynamics.damping_wrench`."""
        linear = self.linear_damping + relative[..., :1] * self.forward_damping
        return -(linear + self.quadratic_damping * np.abs(relative)) * relative

    @classmethod
    def of(cls, links: list[HydroLink], hydro: HydroParameters, gravity: bool) -> StackedLinks:
        """The arrays of ``links`` (their parameters from ``hydro``)."""
        def stack(values, shape) -> np.ndarray:
            return np.array(values, dtype=float).reshape((len(links), *shape))

        buoyancy = stack([hydro.fluid_density * hydro.gravity * link.params.volume if gravity else 0.0
                          for link in links], ())
        return cls(tuple(link.frame_id for link in links), tuple(link.joint_id for link in links),
                   stack([link.placement.inverse().action for link in links], (6, 6)),
                   stack([link.placement.rotation for link in links], (3, 3)),
                   stack([link.placement.translation for link in links], (3,)),
                   stack([link.params.added_mass for link in links], (6, 6)),
                   stack([link.params.linear_damping for link in links], (6,)),
                   stack([link.params.linear_damping_forward_speed for link in links], (6,)),
                   stack([link.params.quadratic_damping for link in links], (6,)),
                   buoyancy, stack([link.params.center_of_buoyancy for link in links], (3,)),
                   bool(np.any(buoyancy > 0.0)))


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
        hydro: the parameters (None: the model's own, see :func:`uvms.dynamics.hydro.hydrodynamics.hydrodynamics_of`).
        q: configuration (nq,).
        frame: end-effector frame (default: the first).

    Raises:
        UVMSError: fixed base; invalid parameters or link names.
    """
    if robot.base_type == "fixed":
        raise UVMSError(f"{robot.name} has a fixed base: there is no free-floating base to conserve momentum")
    state = Configuration(robot, q)
    hydro = hydrodynamics_of(robot, required=False) if hydro is None else hydro
    jacobian = state.jacobian(robot.frame_id(frame))  # before crba overwrites the state's data (read once)
    mass = augmented_mass_matrix(robot.model, state.data, resolve_links(robot.model, hydro), state.q)
    return generalized_jacobian_from_parts(jacobian, *mass_matrix_split(mass, robot.n_vehicle), robot.n_vehicle)
