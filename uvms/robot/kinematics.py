"""Kinematics from the Pinocchio model: poses, world-aligned Jacobians, generalized Jacobian.

Everything here is computed by Pinocchio from the model; no formula of a
particular robot appears. Twists are [linear; angular] with the linear part the
velocity of the frame origin, both in world axes (``LOCAL_WORLD_ALIGNED``),
and Jacobian columns in the order of the velocity vector v.

Generalized Jacobian (free-floating base, no external force): with the
centroidal momentum map h = A v = A_b v_b + A_m qdot_m,

    v_b = A_b^-1 (h - A_m qdot_m)
    twist_ee = J_b v_b + J_m qdot_m = (J_m - J_b A_b^-1 A_m) qdot_m + J_b A_b^-1 h

so GJM = J_m - J_b A_b^-1 A_m. A planar base keeps only the momentum rows
it cannot exchange with the world through its joint: x, y linear and z angular.

The formula is written once, :func:`generalized_jacobian_from_parts`, for any
momentum rows [A_b | A_m] (k, nv) that the vehicle conserves:

* the rigid centroidal map (:func:`centroidal_map_split`, ``Robot.generalized_jacobian``);
* the base rows of a mass matrix, rigid or augmented with the links' added mass
  (:func:`mass_matrix_split`: [M_bb | M_bm], the momentum in the base frame; at
  zero momentum it gives the same GJM as the centroidal rows, M_bb^-1 M_bm = A_b^-1 A_m);
* a vehicle held still (:func:`held_vehicle_split`: [I | 0], GJM = J_m, the
  fixed-base Jacobian of station keeping).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from ..errors import ModelCheckError, NoVehicleError, NumericalError, UVMSError
from ..numerics.lapack import numpy_solve
from .conventions import AXIS_NAMES

WORLD_ALIGNED = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED

#: Rows of the centroidal momentum [linear; angular] conserved by each base type.
CONSERVED_MOMENTUM_ROWS = {"floating": [0, 1, 2, 3, 4, 5], "planar": [0, 1, 5]}


def axis_rows(axes: Sequence[str]) -> list[int]:
    """Row indices in a [vx, vy, vz, wx, wy, wz] twist of named task axes.

    Args:
        axes: any subset of ``("x", "y", "z", "roll", "pitch", "yaw")``.

    Raises:
        UVMSError: unknown or repeated axis names.
    """
    rows = []
    for axis in axes:
        if axis not in AXIS_NAMES:
            raise UVMSError(f"unknown task axis {axis!r}; valid axes: {', '.join(AXIS_NAMES)}")
        if AXIS_NAMES.index(axis) in rows:
            raise UVMSError(f"task axis {axis!r} is given twice")
        rows.append(AXIS_NAMES.index(axis))
    return rows


def support_columns(model: pin.Model, joint: int) -> np.ndarray:
    """The columns of v (m,) of the joints from ``joint`` up to the root: those that move it (a model without mimic
    joints, whose every joint has its own columns)."""
    parents, starts, sizes = model.parents, model.idx_vs, model.nvs  # each read copies Pinocchio's vector: once
    columns = []
    while joint > 0:  # joint 0 is the universe
        start = starts[joint]
        columns.extend(range(start, start + sizes[joint]))
        joint = parents[joint]
    return np.array(sorted(columns), dtype=np.int64)


def centroidal_map_split(
    model: pin.Model, data: pin.Data, q: np.ndarray, base_type: str, n_vehicle: int
) -> tuple[np.ndarray, np.ndarray]:
    """The conserved rows of the centroidal momentum map, split into base and arm columns.

    Returns:
        A_b (k, n_vehicle) and A_m (k, nv - n_vehicle), k = 6 (floating) or 3 (planar).

    Raises:
        NoVehicleError: a fixed base: the model has no vehicle whose momentum is conserved.
    """
    rows = conserved_rows(base_type)
    centroidal_map = pin.computeCentroidalMap(model, data, q)[rows]  # (k, nv)
    return centroidal_map[:, :n_vehicle], centroidal_map[:, n_vehicle:]


def conserved_rows(base_type: str) -> list[int]:
    """Rows of the centroidal momentum [linear; angular] a vehicle of ``base_type`` conserves.

    Raises:
        NoVehicleError: a fixed base (or any kind without a free vehicle): nothing is conserved, the
            generalized Jacobian and the free-floating vehicle velocity are undefined.
    """
    try:
        return CONSERVED_MOMENTUM_ROWS[base_type]
    except KeyError:
        raise NoVehicleError(
            f"the model has no vehicle (base type {base_type!r}): the generalized Jacobian and the free-floating "
            f"vehicle velocity need a floating or planar base; load it with base='floating' or 'planar', or use "
            f"the ordinary Jacobian (jacobian)") from None


def mass_matrix_split(mass: np.ndarray, n_vehicle: int) -> tuple[np.ndarray, np.ndarray]:
    """The vehicle rows of a mass matrix as momentum rows: M_bb (n_vehicle, n_vehicle), M_bm (n_vehicle, n_arm).

    Args:
        mass: M (nv, nv), rigid (``pin.crba``) or augmented with the links' added mass.
        n_vehicle: velocity entries of the vehicle.
    """
    return mass[:n_vehicle, :n_vehicle], mass[:n_vehicle, n_vehicle:]


def held_vehicle_split(n_vehicle: int, n_arm: int) -> tuple[np.ndarray, np.ndarray]:
    """Momentum rows [I | 0] of a vehicle held still (station keeping): v_b = 0 and GJM = J_m exactly."""
    return np.eye(n_vehicle), np.zeros((n_vehicle, n_arm))


def base_velocity_from_momentum(
    a_base: np.ndarray, a_arm: np.ndarray, arm_velocity: np.ndarray, momentum: np.ndarray | None
) -> np.ndarray:
    """Base velocity v_b = A_b^-1 (h - A_m qdot_m) (n_vehicle,), in the base's local axes."""
    rhs = -a_arm @ arm_velocity
    if momentum is not None:
        rhs = rhs + momentum
    return solve_base_block(a_base, rhs)


def generalized_jacobian_from_parts(
    jacobian: np.ndarray, a_base: np.ndarray, a_arm: np.ndarray, n_vehicle: int
) -> np.ndarray:
    """GJM = J_m - J_b A_b^-1 A_m (k, n_arm): the one place the generalized Jacobian is formed.

    Args:
        jacobian: J (k, nv), world-aligned rows of a task, columns in the order of v.
        a_base, a_arm: the conserved momentum rows split into vehicle (r, n_vehicle) and arm (r, n_arm)
            columns: :func:`centroidal_map_split`, :func:`mass_matrix_split` or :func:`held_vehicle_split`.
        n_vehicle: velocity entries of the vehicle.

    Raises:
        ModelCheckError: A_b is singular (:func:`solve_base_block`).
    """
    return jacobian[:, n_vehicle:] - jacobian[:, :n_vehicle] @ solve_base_block(a_base, a_arm)


#: Entries of the momentum map beyond this [kg m^2/s] mean a diverged state, not a model (1e12 is far above any UVMS).
DIVERGED = 1e12


def solve_base_block(a_base: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """A_b^-1 rhs, the one place the vehicle block of the centroidal map is inverted.

    Raises:
        ModelCheckError: A_b is singular: the model has no mass (or no inertia) for the vehicle's
            motion to move, so a free-floating vehicle velocity is undefined.
    """
    # the arrays' own .all(): np.all's dispatch costs more than the pass on these small blocks
    if not (np.isfinite(a_base).all() and np.isfinite(rhs).all()) or np.abs(a_base).max() > DIVERGED:
        raise NumericalError("the momentum map has non-finite or enormous entries: the configuration or the velocities "
                             "diverged (near a singularity without damping?)")
    try:
        with np.errstate(invalid="ignore"):  # a singular block gives NaN, refused here (not numpy's RuntimeWarning)
            return numpy_solve(a_base, rhs)  # np.linalg.solve's numbers
    except NumericalError:
        raise ModelCheckError(
            "the vehicle block of the centroidal momentum map is singular: the model has no mass or inertia "
            "that a free-floating vehicle could exchange momentum with (all links massless?); the generalized "
            "Jacobian and the free-floating vehicle velocity need an <inertial> on the vehicle or the arm links"
        ) from None


def manipulability_of(jacobian: np.ndarray) -> float:
    """Yoshikawa's manipulability sqrt(det(J J^T)), computed as the product of singular values."""
    singular_values = np.linalg.svd(jacobian, compute_uv=False)
    return float(np.prod(singular_values[: min(jacobian.shape)]))


def weight_potential(model: pin.Model, data: pin.Data, q: np.ndarray) -> float:
    """Potential energy [J] of the weight of every body, -m g . c (m the total mass [kg], c (3,) its centre [m]).

    ``pin.computePotentialEnergy`` sums the same -m_i g . c_i per body but refuses mimic joints;
    ``pin.centerOfMass`` places the mimic bodies by their mimic relation.
    """
    center = pin.centerOfMass(model, data, q)
    return -float(data.mass[0]) * float(model.gravity.linear @ center)
