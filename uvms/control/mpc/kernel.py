"""The MPC's prediction model in compiled passes: the hydrodynamic wrenches' derivatives and the acceleration's (the
formulas are in :mod:`uvms.control.mpc.prediction`; the acceleration itself is the plant's,
:meth:`uvms.dynamics.plant.plant.Plant.dynamics`).

Pinocchio's ``computeRNEADerivatives`` gives, in one call, every joint's world Jacobian columns J (6, nv), their time
derivative dJ (6, nv) and the joints' placements. Each link's LOCAL Jacobian J_l = X J and X dJ (X = Ad(oMf)^-1,
oMf = oMi[joint] jMf) are formed from them by the plant's own pass (:func:`uvms.numerics._kernels.hydro.
frame_jacobian_into`, ``getFrameJacobian``'s numbers), and everything else in the link frame from these two, since
X (m x n) = (X m) x (X n): no ``getFrameAccelerationDerivatives`` per link, no ``pin.Force`` per joint (a call from
Python costs more than the arithmetic of a link). Motions are Pinocchio's [linear; angular].

- the link's twist and spatial acceleration: nu = sum_k J_l,k v_k, A = sum_k (J_l,k a_k + (X dJ)_k v_k);
- the same of the parent p of column k's joint: nu_p = sum J_l,m v_m, A_p = sum (J_l,m a_m + (X dJ)_m v_m) over the
  columns m of p's support (the strict ancestors of k's joint);
- the LOCAL derivatives of the link's velocity and spatial acceleration, column k:
  dnu/dq_k = nu_p x J_l,k, dA/dv_k = (nu_p - nu) x J_l,k + (X dJ)_k,
  dA/dq_k = A_p x J_l,k + (nu_p - nu) x (nu_p x J_l,k) (zero when p is the universe; Pinocchio's
  ``getJointAccelerationDerivatives``, LOCAL);
- the wrenches held in the link frames while q moves: d(J_l,i . f)/dq_k = -(J_l,k x J_l,i) . f when joint(k) is a
  strict descendant of joint(i) (the term rnea's derivatives add for an fext).

numba is imported here, so this module is loaded where a prediction's derivatives are first evaluated; the kernels
compile at their first call and are cached on disk.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ...numerics._kernels.hydro import frame_jacobian_into

__all__ = ["forward_derivatives_into", "inverse_dynamics_derivatives_into"]


@njit(cache=True)
def _cross_add(a: np.ndarray, b: np.ndarray, out: np.ndarray, scale: float = 1.0) -> None:
    """out (3,) += scale (a x b), a, b (3,)."""
    out[0] += scale * (a[1] * b[2] - a[2] * b[1])
    out[1] += scale * (a[2] * b[0] - a[0] * b[2])
    out[2] += scale * (a[0] * b[1] - a[1] * b[0])


@njit(cache=True)
def _skew_add(x: np.ndarray, out: np.ndarray) -> None:
    """out (3, 3) += [x]x."""
    out[0, 1] -= x[2]
    out[0, 2] += x[1]
    out[1, 2] -= x[0]
    out[1, 0] += x[2]
    out[2, 0] -= x[1]
    out[2, 1] += x[0]


@njit(cache=True)
def _dot(a: np.ndarray, b: np.ndarray) -> float:
    total = 0.0
    for r in range(a.size):
        total += a[r] * b[r]
    return total


@njit(cache=True)
def _motion_cross(m: np.ndarray, n: np.ndarray, out: np.ndarray) -> None:
    """out (6,) = m x n = [w_m x v_n + v_m x w_n; w_m x w_n] (motions [v; w])."""
    out[0] = m[4] * n[2] - m[5] * n[1] + m[1] * n[5] - m[2] * n[4]
    out[1] = m[5] * n[0] - m[3] * n[2] + m[2] * n[3] - m[0] * n[5]
    out[2] = m[3] * n[1] - m[4] * n[0] + m[0] * n[4] - m[1] * n[3]
    out[3] = m[4] * n[5] - m[5] * n[4]
    out[4] = m[5] * n[3] - m[3] * n[5]
    out[5] = m[3] * n[4] - m[4] * n[3]


@njit(cache=True)
def inverse_dynamics_derivatives_into(jacobian: np.ndarray, d_jacobian: np.ndarray, placements: np.ndarray,
                                      slots: np.ndarray, programs: np.ndarray, starts: np.ndarray,
                                      descends: np.ndarray, link_rotations: np.ndarray, link_translations: np.ndarray,
                                      added_mass: np.ndarray, linear: np.ndarray, forward: np.ndarray,
                                      quadratic: np.ndarray, buoyancy: np.ndarray, center_of_buoyancy: np.ndarray,
                                      current: np.ndarray, with_added_mass: bool, with_damping: bool, v: np.ndarray,
                                      a: np.ndarray, generalized: np.ndarray, d_dq: np.ndarray,
                                      d_dv: np.ndarray) -> None:
    """-sum_l J_l^T f_l into ``generalized`` (nv,) and its derivatives (the wrenches' change and, for dq, the
    Jacobians' while the wrenches are held in their frames) added to d_dq, d_dv (nv, nv).

    Args:
        jacobian, d_jacobian: Pinocchio's data.J, data.dJ (6, nv) at (q, v, a); placements: (K, 4, 4) the links'
            joints' oMi (``slots`` (L,): a link's row in it); programs: (P, 3) the links' walks over data.J
            (:func:`uvms.numerics._kernels.hydro.frame_jacobian_program`: from the joint's last column up to the
            root; no mimic joint, so each column once), link l's rows starts[l]:starts[l + 1];
        descends: (nv, nv) whether column k's joint is a strict descendant of column i's ([k, i]);
        link_rotations, link_translations: (L, 3, 3), (L, 3) the links in their joints;
        added_mass ... current: the plant's stacked link constants (buoyancy 0 where none);
        with_added_mass, with_damping: the plant's; v, a: (nv,).
    """
    count, nv = slots.size, v.size
    local, local_rate = np.zeros((6, nv)), np.zeros((6, nv))  # J_l = X J, X dJ
    rotation = np.empty((3, 3))
    columns = np.empty(nv, dtype=np.int64)  # the columns the link moves with
    nu, acceleration, relative, wrench = np.empty(6), np.empty(6), np.empty(6), np.empty(6)
    current_local, momentum, up, force = np.empty(3), np.empty(6), np.empty(3), np.empty(3)
    rate = np.empty((6, 6))  # d(wrench)/d(nu_r), the added mass's acceleration term aside
    no_inertia = np.zeros((6, 6))
    # per column k: nu_p - nu, dnu/dq_k, dA/dq_k, dA/dv_k, d(R^T v_c)/dq_k, d(wrench)/dq_k, /dv_k
    parent_velocity, parent_acceleration = np.zeros((nv, 6)), np.zeros((nv, 6))  # nu_p, A_p of column k
    sums_above, rates_above, relative_motion = np.zeros(6), np.zeros(6), np.empty(6)
    velocity_dq, acceleration_dq, acceleration_dv = np.empty(6), np.empty(6), np.empty(6)
    current_dq, df_dq, df_dv, out = np.empty(3), np.empty(6), np.empty(6), np.empty(6)
    for link in range(count):
        program = programs[starts[link]:starts[link + 1]]
        placement = placements[slots[link]]
        frame_jacobian_into(jacobian, placement, link_rotations[link], link_translations[link], program, local,
                            rotation)
        frame_jacobian_into(d_jacobian, placement, link_rotations[link], link_translations[link], program,
                            local_rate, rotation)
        moved = program.shape[0]  # (no mimic joint: each column once)
        for step in range(moved):
            columns[step] = program[step, 1]
        # down the chain (the walk reversed: from the root), the sums of the columns above each column's joint
        nu[:] = 0.0
        acceleration[:] = 0.0
        sums_above[:] = 0.0
        rates_above[:] = 0.0
        above = -1
        for step in range(moved - 1, -1, -1):
            k = columns[step]
            if above >= 0 and descends[k, above]:  # a joint further down: the ones above are its ancestors
                sums_above[:] = nu
                rates_above[:] = acceleration
            parent_velocity[k] = sums_above
            parent_acceleration[k] = rates_above
            for r in range(6):
                nu[r] += local[r, k] * v[k]
                acceleration[r] += local[r, k] * a[k] + local_rate[r, k] * v[k]
            above = k
        for i in range(3):  # c = R^T v_c
            current_local[i] = rotation[0, i] * current[0] + rotation[1, i] * current[1] + rotation[2, i] * current[2]
        relative[:] = nu
        relative[:3] -= current_local
        inertia = added_mass[link] if with_added_mass else no_inertia
        wrench[:] = 0.0
        rate[:] = 0.0
        if with_added_mass:  # -C_A(nu_r) nu_r, C_A(nu) nu = [w x a1; v x a1 + w x a2], a = M_A nu
            for r in range(6):
                momentum[r] = _dot(inertia[r], relative)
            rv, rw, a1, a2 = relative[:3], relative[3:], momentum[:3], momentum[3:]
            _cross_add(rw, a1, wrench[:3], -1.0)
            _cross_add(rv, a1, wrench[3:], -1.0)
            _cross_add(rw, a2, wrench[3:], -1.0)
            for j in range(6):  # - [[w]x, 0; [v]x, [w]x] M_A, then the change of a1, a2's arms
                _cross_add(rw, inertia[:3, j], rate[:3, j], -1.0)
                _cross_add(rv, inertia[:3, j], rate[3:, j], -1.0)
                _cross_add(rw, inertia[3:, j], rate[3:, j], -1.0)
            _skew_add(a1, rate[:3, 3:])
            _skew_add(a1, rate[3:, :3])
            _skew_add(a2, rate[3:, 3:])
        if with_damping:  # -(d_l + u d_f + d_q |nu_r|) nu_r, u = nu_r[0]
            for i in range(6):
                wrench[i] -= (linear[link, i] + relative[0] * forward[link, i]
                              + quadratic[link, i] * abs(relative[i])) * relative[i]
                rate[i, i] -= linear[link, i] + relative[0] * forward[link, i] + 2.0 * quadratic[link, i] * abs(
                    relative[i])
                rate[i, 0] -= forward[link, i] * relative[i]
        w = nu[3:]
        _cross_add(w, current_local, acceleration[:3])  # A_l + [w x c; 0]: the acceleration relative to the water
        for r in range(6):
            wrench[r] -= _dot(inertia[r], acceleration)
        buoyant = buoyancy[link] > 0.0
        if buoyant:  # B_l [e; r_b x e], e = R^T e_z, turns with the link
            center = center_of_buoyancy[link]
            for i in range(3):
                up[i] = rotation[2, i]
                force[i] = buoyancy[link] * up[i]
            wrench[:3] += force
            _cross_add(center, force, wrench[3:])
        for step in range(moved):
            i = columns[step]
            generalized[i] -= _dot(local[:, i], wrench)
        for step in range(moved):
            k = columns[step]
            column = local[:, k]
            for r in range(6):
                relative_motion[r] = parent_velocity[k, r] - nu[r]
            _motion_cross(relative_motion, column, acceleration_dv)
            for r in range(6):
                acceleration_dv[r] += local_rate[r, k]
            _motion_cross(parent_velocity[k], column, velocity_dq)  # zero when the parent is the universe
            _motion_cross(parent_acceleration[k], column, acceleration_dq)
            _motion_cross(relative_motion, velocity_dq, out)
            for r in range(6):
                acceleration_dq[r] += out[r]
            # the water's velocity and acceleration seen from the link: d(R^T v_c)/dq_k = c x J_w,k
            current_dq[:] = 0.0
            _cross_add(current_local, column[3:], current_dq)
            velocity_dq[:3] -= current_dq  # now d(nu_r)/dq_k
            _cross_add(w, current_dq, acceleration_dq[:3])
            _cross_add(current_local, velocity_dq[3:], acceleration_dq[:3], -1.0)
            acceleration_dv[:3] -= current_dq
            for r in range(6):
                df_dq[r] = _dot(rate[r], velocity_dq) - _dot(inertia[r], acceleration_dq)
                df_dv[r] = _dot(rate[r], column) - _dot(inertia[r], acceleration_dv)
            if buoyant:  # d e/dq_k = e x J_w,k
                out[:3] = 0.0
                _cross_add(up, column[3:], out[:3], buoyancy[link])
                df_dq[:3] += out[:3]
                _cross_add(center_of_buoyancy[link], out[:3], df_dq[3:])
            for row in range(moved):
                i = columns[row]
                d_dq[i, k] -= _dot(local[:, i], df_dq)
                d_dv[i, k] -= _dot(local[:, i], df_dv)
                if descends[k, i]:  # the Jacobian's change with the wrench held: (J_k x J_i) . f, k below i
                    _motion_cross(column, local[:, i], out)
                    d_dq[i, k] += _dot(out, wrench)


@njit(cache=True)
def forward_derivatives_into(mass: np.ndarray, did_dq: np.ndarray, did_dv: np.ndarray, thrust_map: np.ndarray,
                             time_constant: float, nb: int, da_dq: np.ndarray, da_dv: np.ndarray,
                             da_du: np.ndarray) -> None:
    """(da/dq, da/dv (nv, nv), da/du (nv, nu)) into the given arrays from the inverse dynamics' derivatives:
    da_m/dv_m = -I/tau, da_m/dc = I/tau, and the vehicle rows from Mbar_bb da_b = -(dID_b + Mbar_bm da_m)."""
    nv = mass.shape[0]
    n_arm, n = nv - nb, thrust_map.shape[1]
    da_dq[:] = 0.0
    da_dv[:] = 0.0
    da_du[:] = 0.0
    rate = 1.0 / time_constant
    for i in range(n_arm):
        da_dv[nb + i, nb + i] = -rate
        da_du[nb + i, n + i] = rate
    rhs = np.zeros((nb, 2 * nv + n + n_arm))
    for row in range(nb):
        for k in range(nv):
            rhs[row, k] = -did_dq[row, k]
            rhs[row, nv + k] = -did_dv[row, k]
        for k in range(n_arm):  # - Mbar_bm da_m/dv_m, - Mbar_bm da_m/dc
            rhs[row, nv + nb + k] += mass[row, nb + k] * rate
            rhs[row, 2 * nv + n + k] = -mass[row, nb + k] * rate
        for k in range(n):
            rhs[row, 2 * nv + k] = thrust_map[row, k]
    solved = np.linalg.solve(np.ascontiguousarray(mass[:nb, :nb]), rhs)  # LAPACK's gesv, as the plant's solve
    for row in range(nb):
        for k in range(nv):
            da_dq[row, k] = solved[row, k]
            da_dv[row, k] = solved[row, nv + k]
        for k in range(n + n_arm):
            da_du[row, k] = solved[row, 2 * nv + k]
