"""The hydrodynamic terms of the plant's equations of motion, every link in one compiled pass.

:meth:`uvms.dynamics.plant.plant.Plant._mass_and_bias`: Pinocchio gives the rigid mass matrix, h(q, v), the links'
LOCAL Jacobians J_l, their joints' bias accelerations and rotations; here each link's Fossen wrench f_l (link
frame) is formed and summed by virtual work, Mbar += sum_l J_l^T M_A,l J_l and nbar -= sum_l J_l^T f_l (the
derivation is the docstring of :mod:`uvms.dynamics.plant.plant`). Compiled, because as numpy calls on arrays of a
few rows it is about thirty calls, each dominated by the interpreter's overhead.

The module imports numba, so it is loaded where a plant is first evaluated; its kernel compiles at its first call
and is cached on disk (``cache=True``, see :mod:`uvms.numerics._kernels`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["hydro_terms_into", "pack_links", "plant_terms_into"]

#: Columns of a link's row in :func:`pack_links`: motion_to_link (36), added mass (36), linear, forward, quadratic
#: damping (6 each), buoyancy (1), centre of buoyancy (3).
PACKED = 94


@njit(cache=True)
def _cross(a0: float, a1: float, a2: float, b0: float, b1: float, b2: float) -> tuple[float, float, float]:
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@njit(cache=True)
def hydro_terms_into(jacobians: np.ndarray, v: np.ndarray, joint_bias: np.ndarray, rotations: np.ndarray,
                     motion_to_link: np.ndarray, added_mass: np.ndarray, linear: np.ndarray, forward: np.ndarray,
                     quadratic: np.ndarray, buoyancy: np.ndarray, center_of_buoyancy: np.ndarray, current: np.ndarray,
                     with_added_mass: bool,
                     with_damping: bool, with_current: bool, with_buoyancy: bool, mass: np.ndarray,
                     bias_forces: np.ndarray) -> None:
    """Add the links' added mass to ``mass`` and subtract their wrenches' generalized forces from ``bias_forces``.

    Args:
        jacobians: J_l (L, 6, nv), LOCAL frame Jacobians of the links; v: (nv,) the velocity.
        joint_bias: (L, 6) the spatial bias acceleration of each link's joint (its frame), Pinocchio's data.a.
        rotations: (L, 3, 3) the links' rotations in the world (read only with a current or buoyancy).
        motion_to_link: (L, 6, 6) a joint-frame motion in the link frame; added_mass: M_A (L, 6, 6);
        linear, forward, quadratic: (L, 6) damping d_l, d_f, d_q: -(d_l + u d_f + d_q |nu_r|) nu_r, u = nu_r[0]
            (uuv_simulator's forward-speed term); buoyancy: (L,) rho g V [N];
        center_of_buoyancy: (L, 3) [m] link frame; current: (3,) world [m/s].
        with_added_mass, with_damping, with_current, with_buoyancy: which terms are on.
        mass: Mbar (nv, nv), updated in place; bias_forces: nbar (nv,), updated in place.
    """
    count, _, nv = jacobians.shape
    nu = np.empty(6)
    relative = np.empty(6)
    rate = np.zeros(6)  # Jdot_l v - nu_c'
    wrench = np.empty(6)
    for link in range(count):
        jacobian = jacobians[link]
        for row in range(6):
            total = 0.0
            for column in range(nv):
                total += jacobian[row, column] * v[column]
            nu[row] = total
            relative[row] = total
        if with_current:  # nu_r = nu - [R^T v_c; 0]; nu_c' = [-w x R^T v_c; 0]
            rotation = rotations[link]
            c0 = rotation[0, 0] * current[0] + rotation[1, 0] * current[1] + rotation[2, 0] * current[2]
            c1 = rotation[0, 1] * current[0] + rotation[1, 1] * current[1] + rotation[2, 1] * current[2]
            c2 = rotation[0, 2] * current[0] + rotation[1, 2] * current[1] + rotation[2, 2] * current[2]
            relative[0] -= c0
            relative[1] -= c1
            relative[2] -= c2
        for row in range(6):
            wrench[row] = 0.0
        if with_added_mass:
            for row in range(6):
                total = 0.0
                for column in range(6):
                    total += motion_to_link[link, row, column] * joint_bias[link, column]
                rate[row] = total
            if with_current:  # the current's body-frame rate: -nu_c' = [w x R^T v_c; 0]
                w0, w1, w2 = _cross(nu[3], nu[4], nu[5], c0, c1, c2)
                rate[0] += w0
                rate[1] += w1
                rate[2] += w2
            inertia = added_mass[link]
            a = np.empty(6)
            for row in range(6):
                total = 0.0
                accelerating = 0.0
                for column in range(6):
                    total += inertia[row, column] * relative[column]
                    accelerating += inertia[row, column] * rate[column]
                a[row] = total
                wrench[row] -= accelerating
            # C_A(nu_r) nu_r = [w x a1; v x a1 + w x a2] (Fossen 2011, eq. 6.43)
            x0, x1, x2 = _cross(relative[3], relative[4], relative[5], a[0], a[1], a[2])
            y0, y1, y2 = _cross(relative[0], relative[1], relative[2], a[0], a[1], a[2])
            z0, z1, z2 = _cross(relative[3], relative[4], relative[5], a[3], a[4], a[5])
            wrench[0] -= x0
            wrench[1] -= x1
            wrench[2] -= x2
            wrench[3] -= y0 + z0
            wrench[4] -= y1 + z1
            wrench[5] -= y2 + z2
            for row in range(nv):  # Mbar += J^T M_A J
                for column in range(nv):
                    total = 0.0
                    for i in range(6):
                        if jacobian[i, row] == 0.0:
                            continue
                        inner = 0.0
                        for k in range(6):
                            inner += inertia[i, k] * jacobian[k, column]
                        total += jacobian[i, row] * inner
                    mass[row, column] += total
        if with_damping:
            surge = relative[0]
            for row in range(6):
                wrench[row] -= (linear[link, row] + surge * forward[link, row]
                                + quadratic[link, row] * abs(relative[row])) * relative[row]
        if with_buoyancy and buoyancy[link] > 0.0:  # R^T [0, 0, rho g V] at the centre of buoyancy
            rotation, up = rotations[link], buoyancy[link]
            f0, f1, f2 = rotation[2, 0] * up, rotation[2, 1] * up, rotation[2, 2] * up
            center = center_of_buoyancy[link]
            m0, m1, m2 = _cross(center[0], center[1], center[2], f0, f1, f2)
            wrench[0] += f0
            wrench[1] += f1
            wrench[2] += f2
            wrench[3] += m0
            wrench[4] += m1
            wrench[5] += m2
        for column in range(nv):  # nbar -= J^T f
            total = 0.0
            for row in range(6):
                total += jacobian[row, column] * wrench[row]
            bias_forces[column] -= total


def pack_links(motion_to_link: np.ndarray, added_mass: np.ndarray, linear: np.ndarray, forward: np.ndarray,
               quadratic: np.ndarray, buoyancy: np.ndarray, center_of_buoyancy: np.ndarray) -> np.ndarray:
    """The links' constants as one (L, :data:`PACKED`) array: one argument of :func:`plant_terms_into` instead of
    seven (numba's dispatch costs about a microsecond per array argument)."""
    count = len(buoyancy)
    return np.ascontiguousarray(np.concatenate(
        [motion_to_link.reshape(count, 36), added_mass.reshape(count, 36), linear.reshape(count, 6),
         forward.reshape(count, 6), quadratic.reshape(count, 6), buoyancy.reshape(count, 1),
         center_of_buoyancy.reshape(count, 3)], axis=1), dtype=float)


@njit(cache=True)
def plant_terms_into(upper: np.ndarray, h: np.ndarray, jacobians: np.ndarray, v: np.ndarray, joint_bias: np.ndarray,
                     rotations: np.ndarray, packed: np.ndarray, current: np.ndarray, flags: np.ndarray,
                     mass: np.ndarray, bias_forces: np.ndarray) -> None:
    """Mbar and nbar of the plant's links in one call: :func:`hydro_terms_into` on Pinocchio's M (its upper
    triangle, as crba fills it) and h.

    Args:
        upper: M (nv, nv), its upper triangle read; h: (nv,) rnea's bias forces.
        jacobians, v, joint_bias, rotations, current: as for :func:`hydro_terms_into` (L may be 0).
        packed: the links' constants (L, PACKED) (:func:`pack_links`).
        flags: (4,) int: added mass, damping, current, buoyancy on.
        mass: Mbar (nv, nv) out; bias_forces: nbar (nv,) out.
    """
    nv = h.shape[0]
    for row in range(nv):
        bias_forces[row] = h[row]
        for column in range(nv):
            mass[row, column] = upper[row, column] if column >= row else upper[column, row]
    count = jacobians.shape[0]
    if count:
        hydro_terms_into(jacobians, v, joint_bias, rotations, packed[:, 0:36].copy().reshape(count, 6, 6),
                         packed[:, 36:72].copy().reshape(count, 6, 6), packed[:, 72:78].copy(),
                         packed[:, 78:84].copy(), packed[:, 84:90].copy(), packed[:, 90].copy(),
                         packed[:, 91:94].copy(), current, flags[0] != 0, flags[1] != 0, flags[2] != 0,
                         flags[3] != 0, mass, bias_forces)
