"""Screw (twist) formulation of santos2006: virtual PPPS chain and the Davies method.

Twists are written [omega; v_O] with v_O the velocity of the body point at the
world origin (Plucker coordinates). The joint screws of the UVMS chain are the
columns of its world-aligned Jacobian moved to the origin; a virtual chain
P_x P_y P_z S (spherical joint at the end-effector point) closes the loop, and
the circulation law gives the network equation N Y = 0, N = [S_uvms | -S_virtual].
Splitting the magnitudes Y into primary (imposed) and secondary (unknown) ones:
N_s Y_s = -N_p Y_p.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..errors import SolverInputError
from ..numerics.checks import check_matrix, check_vector
from ..robot.configuration import Configuration

#: Virtual joints of the PPPS chain, in order (prismatic x, y, z; spherical as rotations about x, y, z).
VIRTUAL_JOINTS = ("px", "py", "pz", "rx", "ry", "rz")
#: Rows [omega_z, v_Ox, v_Oy] and virtual joints (px, py, rz) of a planar (x-y) system.
PLANAR_ROWS = [2, 3, 4]
PLANAR_VIRTUAL = [0, 1, 5]


def twist_at_origin(world_aligned: np.ndarray, point: np.ndarray) -> np.ndarray:
    """[omega; v_O] (6, n) from world-aligned [v_p; omega] columns (6, n) of a point p."""
    linear, angular = world_aligned[:3], world_aligned[3:]
    return np.vstack([angular, linear - np.cross(angular.T, point).T])  # v_O = v_p - omega x p


def uvms_screws(state: Configuration, frame_id: int) -> np.ndarray:
    """Screws of the UVMS chain (6, nv): the Jacobian columns as twists at the world origin."""
    return twist_at_origin(state.jacobian(frame_id), state.pose(frame_id).translation)


def ppps_screws(point: np.ndarray) -> np.ndarray:
    """Normalized screws (6, 6) of the virtual P_x P_y P_z S chain whose spherical joint is at ``point``."""
    screws = np.zeros((6, 6))
    screws[3:, :3] = np.eye(3)  # prismatic: [0; e_i]
    screws[:3, 3:] = np.eye(3)  # revolute through p: [e_i; p x e_i]
    screws[3:, 3:] = np.cross(point, np.eye(3)).T
    return screws


def network_matrix(state: Configuration, frame_id: int, planar: bool = False) -> np.ndarray:
    """N = [S_uvms | -S_virtual] (6, nv + 6), or its planar rows/virtual joints (3, nv + 3)."""
    virtual = ppps_screws(state.pose(frame_id).translation)
    network = np.hstack([uvms_screws(state, frame_id), -virtual])
    if planar:
        columns = list(range(state.robot.nv)) + [state.robot.nv + j for j in PLANAR_VIRTUAL]
        return network[np.ix_(PLANAR_ROWS, columns)]
    return network


def davies_solve(network: np.ndarray, primary: Sequence[int], primary_values: np.ndarray) -> np.ndarray:
    """Secondary magnitudes Y_s from N_s Y_s = -N_p Y_p (exact when N_s is square and regular).

    Args:
        network: N (rows, columns).
        primary: column indices of the imposed magnitudes.
        primary_values: their values Y_p.

    Returns:
        Y (columns,) with the primary entries as given and the secondary ones solved.
    """
    network = check_matrix(network, "N")
    primary = list(primary)
    primary_values = check_vector(primary_values, "Y_p", len(primary))
    secondary = [column for column in range(network.shape[1]) if column not in primary]
    n_secondary = network[:, secondary]
    if n_secondary.shape[0] != n_secondary.shape[1]:
        raise SolverInputError(
            f"the secondary matrix is {n_secondary.shape}: impose {len(secondary) - network.shape[0]} more magnitudes")
    magnitudes = np.zeros(network.shape[1])
    magnitudes[primary] = primary_values
    magnitudes[secondary] = np.linalg.solve(n_secondary, -network[:, primary] @ primary_values)
    return magnitudes
