"""The MPC's prediction model in compiled passes: the links' kinematics from Pinocchio's world Jacobians, the plant's
acceleration, and the hydrodynamic wrenches' derivatives (the formulas are in :mod:`uvms.control.mpc.prediction`).

Pinocchio gives, in one call per evaluation, every joint's world Jacobian columns J (6, nv) and their time
derivative dJ (6, nv) (``computeJointJacobiansTimeVariation`` or ``computeRNEADerivatives``), and the joints'
placements. Everything per link is formed here from them, in the order Pinocchio's own getters would (no
``getFrameJacobian``/``getFrameAccelerationDerivatives`` per link, no ``pin.Force`` per joint): a call from Python
costs more than the arithmetic of a link. Motions are Pinocchio's [linear; angular], spatial at the world origin.

- a joint's world velocity and acceleration: ov_j = sum_{k in supp j} J_k v_k, oa_j = sum (J_k a_k + dJ_k v_k);
- a link's LOCAL quantities: X = Ad(oMf)^-1 (oMf = oMi[joint] jMf) applied to the world ones;
- the LOCAL derivatives of a link's velocity and spatial acceleration, column k of joint i (parent p):
  dnu/dq_k = X (ov_p x J_k), dA/dv_k = X ((ov_p - ov_j) x J_k + dJ_k),
  dA/dq_k = X (oa_p x J_k + (ov_p - ov_j) x (ov_p x J_k)) (zero when p is the universe; Pinocchio's
  ``getJointAccelerationDerivatives``, LOCAL);
- the wrenches held in the link frames while q moves: d(J_l,i . f)/dq_k = -(J_l,k x J_l,i) . f when joint(k) is a
  strict descendant of joint(i) (the term rnea's derivatives add for an fext).

numba is imported here, so this module is loaded where a prediction is first evaluated; the kernels compile at
their first call and are cached on disk.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ...numerics._kernels.hydro import hydro_terms_into

__all__ = ["dynamics_into", "forward_derivatives_into", "inverse_dynamics_derivatives_into"]


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
def _motion_cross(m: np.ndarray, n: np.ndarray, out: np.ndarray) -> None:
    """out (6,) = m x n = [w_m x v_n + v_m x w_n; w_m x w_n] (motions [v; w])."""
    out[0] = m[4] * n[2] - m[5] * n[1] + m[1] * n[5] - m[2] * n[4]
    out[1] = m[5] * n[0] - m[3] * n[2] + m[2] * n[3] - m[0] * n[5]
    out[2] = m[3] * n[1] - m[4] * n[0] + m[0] * n[4] - m[1] * n[3]
    out[3] = m[4] * n[5] - m[5] * n[4]
    out[4] = m[5] * n[3] - m[3] * n[5]
    out[5] = m[3] * n[4] - m[4] * n[3]


@njit(cache=True)
def _inverse_action(rotation: np.ndarray, translation: np.ndarray, motion: np.ndarray, out: np.ndarray) -> None:
    """out (6,) = Ad(M)^-1 motion, M = (rotation, translation): [R^T (v - p x w); R^T w]."""
    p, v0, v1, v2, w0, w1, w2 = translation, motion[0], motion[1], motion[2], motion[3], motion[4], motion[5]
    v0 -= p[1] * w2 - p[2] * w1
    v1 -= p[2] * w0 - p[0] * w2
    v2 -= p[0] * w1 - p[1] * w0
    for i in range(3):
        out[i] = rotation[0, i] * v0 + rotation[1, i] * v1 + rotation[2, i] * v2
        out[3 + i] = rotation[0, i] * w0 + rotation[1, i] * w1 + rotation[2, i] * w2


@njit(cache=True)
def _joint_motions(jacobian: np.ndarray, d_jacobian: np.ndarray, v: np.ndarray, a: np.ndarray,
                   support: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(ov, oa) (njoints, 6): every joint's world spatial velocity and acceleration (the universe's zero)."""
    count, nv = support.shape
    ov, oa = np.zeros((count, 6)), np.zeros((count, 6))
    for joint in range(count):
        for k in range(nv):
            if support[joint, k]:
                for r in range(6):
                    ov[joint, r] += jacobian[r, k] * v[k]
                    oa[joint, r] += jacobian[r, k] * a[k] + d_jacobian[r, k] * v[k]
    return ov, oa


@njit(cache=True)
def _link_placement(placement: np.ndarray, rotation: np.ndarray,
                    translation: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(R (3, 3), p (3,)) of a link: its joint's placement (4, 4) times the link's in the joint (R, p)."""
    joint_rotation = np.ascontiguousarray(placement[:3, :3])
    return joint_rotation @ rotation, placement[:3, 3] + joint_rotation @ translation


@njit(cache=True)
def _solve_into(matrix: np.ndarray, rhs: np.ndarray, out: np.ndarray) -> None:
    """out (n, m) = matrix^-1 rhs (n, m): Gaussian elimination with partial pivoting (n small)."""
    n, m = rhs.shape
    a = matrix.copy()
    b = rhs.copy()
    for col in range(n):
        pivot = col
        for row in range(col + 1, n):
            if abs(a[row, col]) > abs(a[pivot, col]):
                pivot = row
        if pivot != col:
            for k in range(n):
                a[col, k], a[pivot, k] = a[pivot, k], a[col, k]
            for k in range(m):
                b[col, k], b[pivot, k] = b[pivot, k], b[col, k]
        for row in range(col + 1, n):
            factor = a[row, col] / a[col, col]
            if factor != 0.0:
                for k in range(col, n):
                    a[row, k] -= factor * a[col, k]
                for k in range(m):
                    b[row, k] -= factor * b[col, k]
    for row in range(n - 1, -1, -1):
        for k in range(m):
            total = b[row, k]
            for j in range(row + 1, n):
                total -= a[row, j] * out[j, k]
            out[row, k] = total / a[row, row]


@njit(cache=True)
def dynamics_into(jacobian: np.ndarray, d_jacobian: np.ndarray, placements: np.ndarray, slots: np.ndarray,
                  joints: np.ndarray, support: np.ndarray, link_rotations: np.ndarray,
                  link_translations: np.ndarray, motion_to_link: np.ndarray, added_mass: np.ndarray,
                  linear: np.ndarray, forward: np.ndarray, quadratic: np.ndarray, buoyancy: np.ndarray,
                  center_of_buoyancy: np.ndarray, current: np.ndarray, flags: np.ndarray, v: np.ndarray,
                  command: np.ndarray, generalized_force: np.ndarray, time_constant: float, nb: int,
                  mass: np.ndarray, bias_forces: np.ndarray, acceleration: np.ndarray, torque: np.ndarray) -> None:
    """The plant's acceleration (:meth:`uvms.dynamics.plant.plant.Plant.dynamics`, its hydrodynamic kernel on the
    links' kinematics formed here).

    Args:
        jacobian, d_jacobian: Pinocchio's data.J, data.dJ (6, nv) at (q, v); placements: (K, 4, 4) the joints'
            (``slots`` (L,): a link's row in it); joints: (L,) the links' joints; support: (njoints, nv) the
            columns each joint moves with; link_rotations, link_translations: (L, 3, 3), (L, 3) the links in their
            joints; motion_to_link ... center_of_buoyancy, current: the plant's stacked link constants;
            flags: (4,) added mass, damping, current, buoyancy on (1) or off (0).
        v: (nv,); command: (n_arm,) the arm's velocity commands; generalized_force: (nv,) the thrusters' and the
            disturbance's; time_constant: [s] the servos'; nb: the vehicle's velocity coordinates.
        mass: (nv, nv) crba's upper triangle in, Mbar out; bias_forces: (nv,) rnea(q, v, 0) in, nbar out.
        acceleration: (nv,) out; torque: (n_arm,) out, the motors'.
    """
    count, nv = joints.size, v.size
    links = np.zeros((count, 6, nv))
    joint_bias = np.zeros((count, 6))
    rotations = np.zeros((count, 3, 3))
    world = np.zeros(6)
    column = np.zeros(6)
    for link in range(count):
        joint = joints[link]
        placement = placements[slots[link]]
        rotation, translation = _link_placement(placement, link_rotations[link], link_translations[link])
        rotations[link] = rotation
        for k in range(nv):
            if support[joint, k]:
                _inverse_action(rotation, translation, jacobian[:, k], column)
                links[link, :, k] = column
        for r in range(6):  # the joint's bias acceleration dJ v, in its own frame (Pinocchio's data.a, a = 0)
            total = 0.0
            for k in range(nv):
                if support[joint, k]:
                    total += d_jacobian[r, k] * v[k]
            world[r] = total
        joint_rotation = np.ascontiguousarray(placement[:3, :3])
        _inverse_action(joint_rotation, placement[:3, 3].copy(), world, column)
        joint_bias[link] = column
    for row in range(nv):  # crba fills the upper triangle
        for col in range(row):
            mass[row, col] = mass[col, row]
    hydro_terms_into(links, v, joint_bias, rotations, motion_to_link, added_mass, linear, forward, quadratic,
                     buoyancy, center_of_buoyancy, current, flags[0] > 0, flags[1] > 0, flags[2] > 0, flags[3] > 0,
                     mass, bias_forces)
    n_arm = nv - nb
    for i in range(n_arm):
        acceleration[nb + i] = (command[i] - v[nb + i]) / time_constant
    rhs = np.zeros((nb, 1))
    for row in range(nb):
        total = generalized_force[row] - bias_forces[row]
        for k in range(n_arm):
            total -= mass[row, nb + k] * acceleration[nb + k]
        rhs[row, 0] = total
    base = np.zeros((nb, 1))
    _solve_into(np.ascontiguousarray(mass[:nb, :nb]), rhs, base)
    for row in range(nb):
        acceleration[row] = base[row, 0]
    for i in range(n_arm):
        total = bias_forces[nb + i] - generalized_force[nb + i]
        for k in range(nv):
            total += mass[nb + i, k] * acceleration[k]
        torque[i] = total


@njit(cache=True)
def inverse_dynamics_derivatives_into(jacobian: np.ndarray, d_jacobian: np.ndarray, placements: np.ndarray,
                                      slots: np.ndarray, joints: np.ndarray, support: np.ndarray,
                                      parents: np.ndarray, descends: np.ndarray, link_rotations: np.ndarray,
                                      link_translations: np.ndarray, added_mass: np.ndarray, linear: np.ndarray,
                                      forward: np.ndarray, quadratic: np.ndarray, buoyancy: np.ndarray,
                                      center_of_buoyancy: np.ndarray, current: np.ndarray, with_added_mass: bool,
                                      with_damping: bool, v: np.ndarray, a: np.ndarray, generalized: np.ndarray,
                                      d_dq: np.ndarray, d_dv: np.ndarray) -> None:
    """-sum_l J_l^T f_l into ``generalized`` (nv,) and its derivatives (the wrenches' change and, for dq, the
    Jacobians' while the wrenches are held in their frames) added to d_dq, d_dv (nv, nv).

    Args:
        jacobian, d_jacobian, placements, slots, joints, support, link_rotations, link_translations: as
            :func:`dynamics_into`, at (q, v, a); parents: (nv,) the parent joint of each column's joint;
        descends: (nv, nv) whether column k's joint is a strict descendant of column i's ([k, i]);
        added_mass ... current: the plant's stacked link constants (buoyancy 0 where none);
        with_added_mass, with_damping: the plant's; v, a: (nv,).
    """
    count, nv = joints.size, v.size
    ov, oa = _joint_motions(jacobian, d_jacobian, v, a, support)
    local = np.zeros((6, nv))
    velocity_dq, acceleration_dq, acceleration_dv = np.zeros((6, nv)), np.zeros((6, nv)), np.zeros((6, nv))
    spatial, relative_motion, inner, out = np.zeros(6), np.zeros(6), np.zeros(6), np.zeros(6)
    for link in range(count):
        joint = joints[link]
        rotation, translation = _link_placement(placements[slots[link]], link_rotations[link],
                                                link_translations[link])
        local[:] = 0.0
        velocity_dq[:] = 0.0
        acceleration_dq[:] = 0.0
        acceleration_dv[:] = 0.0
        for k in range(nv):
            if not support[joint, k]:
                continue
            column = jacobian[:, k]
            _inverse_action(rotation, translation, column, out)
            local[:, k] = out
            parent = parents[k]
            for r in range(6):
                relative_motion[r] = ov[parent, r] - ov[joint, r]  # ov[0] = 0: the universe
            _motion_cross(relative_motion, column, spatial)
            for r in range(6):
                spatial[r] += d_jacobian[r, k]
            _inverse_action(rotation, translation, spatial, out)
            acceleration_dv[:, k] = out
            if parent > 0:
                _motion_cross(ov[parent], column, inner)
                _inverse_action(rotation, translation, inner, out)
                velocity_dq[:, k] = out
                _motion_cross(oa[parent], column, spatial)
                _motion_cross(relative_motion, inner, out)
                for r in range(6):
                    spatial[r] += out[r]
                _inverse_action(rotation, translation, spatial, out)
                acceleration_dq[:, k] = out
        nu = np.zeros(6)
        _inverse_action(rotation, translation, ov[joint], nu)
        acceleration = np.zeros(6)
        _inverse_action(rotation, translation, oa[joint], acceleration)
        c = rotation.T @ current
        w = nu[3:].copy()
        relative = nu.copy()
        relative[:3] -= c
        inertia = np.ascontiguousarray(added_mass[link]) if with_added_mass else np.zeros((6, 6))
        wrench = np.zeros(6)
        rate = np.zeros((6, 6))
        if with_added_mass:  # -C_A(nu_r) nu_r, C_A(nu) nu = [w x a1; v x a1 + w x a2], a = M_A nu
            am = inertia @ relative
            a1, a2 = am[:3].copy(), am[3:].copy()
            rv, rw = relative[:3].copy(), relative[3:].copy()
            wrench[:3] -= _cross(rw, a1)
            wrench[3:] -= _cross(rv, a1) + _cross(rw, a2)
            coupling = np.zeros((6, 6))
            coupling[:3, :3] = _skew(rw)
            coupling[3:, :3] = _skew(rv)
            coupling[3:, 3:] = _skew(rw)
            rate -= coupling @ inertia
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
        acceleration[:3] += _cross(w, c)  # A_l + [w x c; 0]: the acceleration relative to the water
        wrench -= inertia @ acceleration
        skew_c = _skew(c)
        jw = np.ascontiguousarray(local[3:])
        dc_dq = skew_c @ jw  # d(R^T v_c)/dq
        drelative_dq = velocity_dq.copy()
        drelative_dq[:3] -= dc_dq
        dacc_dq = acceleration_dq.copy()
        dacc_dq[:3] += -skew_c @ np.ascontiguousarray(velocity_dq[3:]) + _skew(w) @ dc_dq
        dacc_dv = acceleration_dv.copy()
        dacc_dv[:3] -= skew_c @ jw
        df_dq = rate @ drelative_dq - inertia @ dacc_dq
        df_dv = rate @ local - inertia @ dacc_dv
        if buoyancy[link] > 0.0:  # B_l [e; r_b x e], e = R^T e_z, turns with the link
            up = rotation[2].copy()
            force = buoyancy[link] * up
            center = center_of_buoyancy[link].copy()
            wrench[:3] += force
            wrench[3:] += _cross(center, force)
            de_dq = buoyancy[link] * (_skew(up) @ jw)
            df_dq[:3] += de_dq
            df_dq[3:] += _skew(center) @ de_dq
        transposed = np.ascontiguousarray(local.T)
        generalized -= transposed @ wrench
        d_dq -= transposed @ df_dq
        d_dv -= transposed @ df_dv
        for k in range(nv):  # the Jacobian's change with the wrench held: (J_k x J_i) . f, k below i
            if not support[joint, k]:
                continue
            for i in range(nv):
                if descends[k, i]:
                    _motion_cross(local[:, k], local[:, i], out)
                    total = 0.0
                    for r in range(6):
                        total += out[r] * wrench[r]
                    d_dq[i, k] += total


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
    solved = np.zeros_like(rhs)
    _solve_into(np.ascontiguousarray(mass[:nb, :nb]), rhs, solved)
    for row in range(nb):
        for k in range(nv):
            da_dq[row, k] = solved[row, k]
            da_dv[row, k] = solved[row, nv + k]
        for k in range(n + n_arm):
            da_du[row, k] = solved[row, 2 * nv + k]
