"""The links' hydrodynamic wrenches and their derivatives in one compiled pass (the MPC's prediction model).

The formulas are in :mod:`uvms.control.mpc.prediction`; this is their loop over links, written with small explicit
loops because a numpy call on (6, 6) arrays costs more in dispatch than in arithmetic (as
:mod:`uvms.numerics._kernels.hydro`, the plant's own terms). numba is imported here, so this module is loaded where a
prediction is first differentiated; the kernel compiles at its first call and is cached on disk.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["link_wrench_derivatives"]


@njit(cache=True)
def _skew(x: np.ndarray) -> np.ndarray:
    out = np.zeros((3, 3))
    out[0, 1], out[0, 2], out[1, 2] = -x[2], x[1], -x[0]
    out[1, 0], out[2, 0], out[2, 1] = x[2], -x[1], x[0]
    return out


@njit(cache=True)
def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


@njit(cache=True)
def link_wrench_derivatives(velocity_dq: np.ndarray, jacobians: np.ndarray, acceleration_dq: np.ndarray,
                            acceleration_dv: np.ndarray, v: np.ndarray, accelerations: np.ndarray,
                            rotations: np.ndarray, added_mass: np.ndarray, linear: np.ndarray, forward: np.ndarray,
                            quadratic: np.ndarray, buoyancy: np.ndarray, center_of_buoyancy: np.ndarray,
                            current: np.ndarray, with_added_mass: bool, with_damping: bool,
                            wrenches: np.ndarray, d_dq: np.ndarray, d_dv: np.ndarray) -> None:
    """The links' wrenches f_l (L, 6) into ``wrenches``; -sum_l J_l^T df_l/dq and /dv added to d_dq, d_dv (nv, nv).

    Args:
        velocity_dq: (L, 6, nv) d nu_l / dq; jacobians: J_l (L, 6, nv) (LOCAL, = d nu_l / dv);
        acceleration_dq, acceleration_dv: (L, 6, nv) d A_l / dq, dv of the links' spatial accelerations;
        v: (nv,); accelerations: A_l (L, 6); rotations: (L, 3, 3) link to world;
        added_mass: (L, 6, 6); linear, forward, quadratic: (L, 6) the damping; buoyancy: (L,) [N] (0: none);
        center_of_buoyancy: (L, 3) [m]; current: (3,) world [m/s]; with_added_mass, with_damping: the plant's.
    """
    count, _, nv = jacobians.shape
    for link in range(count):
        jacobian = np.ascontiguousarray(jacobians[link])
        nu = jacobian @ v
        rotation = rotations[link]
        c = rotation.T @ current
        w = nu[3:].copy()
        relative = nu.copy()
        relative[:3] -= c
        inertia = np.ascontiguousarray(added_mass[link]) if with_added_mass else np.zeros((6, 6))
        wrench = np.zeros(6)
        rate = np.zeros((6, 6))
        if with_added_mass:  # -C_A(nu_r) nu_r, C_A(nu) nu = [w x a1; v x a1 + w x a2], a = M_A nu
            a = inertia @ relative
            a1, a2 = a[:3].copy(), a[3:].copy()
            rv, rw = relative[:3].copy(), relative[3:].copy()
            wrench[:3] -= _cross(rw, a1)
            wrench[3:] -= _cross(rv, a1) + _cross(rw, a2)
            inner = np.zeros((6, 6))
            inner[:3, :3] = _skew(rw)
            inner[3:, :3] = _skew(rv)
            inner[3:, 3:] = _skew(rw)
            rate -= inner @ inertia
            rate[:3, 3:] += _skew(a1)
            rate[3:, :3] += _skew(a1)
            rate[3:, 3:] += _skew(a2)
        if with_damping:  # -(d_l + u d_f + d_q |nu_r|) nu_r, u = nu_r[0]
            for i in range(6):
                wrench[i] -= (linear[link, i] + relative[0] * forward[link, i]
                              + quadratic[link, i] * abs(relative[i])) * relative[i]
                rate[i, i] -= linear[link, i] + relative[0] * forward[link, i] + 2.0 * quadratic[link, i] * abs(
                    relative[i])
                rate[i, 0] -= forward[link, i] * relative[i]
        acceleration = accelerations[link].copy()  # A_l + [w x c; 0]: the acceleration relative to the water
        acceleration[:3] += _cross(w, c)
        wrench -= inertia @ acceleration
        skew_c = _skew(c)
        jw = np.ascontiguousarray(jacobian[3:])
        dc_dq = skew_c @ jw  # d(R^T v_c)/dq
        dnu_dq = np.ascontiguousarray(velocity_dq[link])
        drelative_dq = dnu_dq.copy()
        drelative_dq[:3] -= dc_dq
        dacc_dq = acceleration_dq[link].copy()
        dacc_dq[:3] += -skew_c @ np.ascontiguousarray(dnu_dq[3:]) + _skew(w) @ dc_dq
        dacc_dv = acceleration_dv[link].copy()
        dacc_dv[:3] -= skew_c @ jw
        df_dq = rate @ drelative_dq - inertia @ dacc_dq
        df_dv = rate @ jacobian - inertia @ dacc_dv
        if buoyancy[link] > 0.0:  # B_l [e; r_b x e], e = R^T e_z, turns with the link
            up = rotation[2].copy()
            force = buoyancy[link] * up
            center = center_of_buoyancy[link].copy()
            wrench[:3] += force
            wrench[3:] += _cross(center, force)
            de_dq = buoyancy[link] * (_skew(up) @ jw)
            df_dq[:3] += de_dq
            df_dq[3:] += _skew(center) @ de_dq
        wrenches[link] = wrench
        transposed = np.ascontiguousarray(jacobian.T)
        d_dq -= transposed @ df_dq
        d_dv -= transposed @ df_dv
