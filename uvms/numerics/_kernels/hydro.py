"""The hydrodynamic terms of the plant's equations of motion, every link in one compiled pass.

:meth:`uvms.dynamics.plant.plant.Plant._mass_and_bias`: Pinocchio gives the rigid mass matrix, h(q, v), its world
Jacobian (one array), the links' joints' placements and bias accelerations; here each link's LOCAL Jacobian J_l is
formed from them (Pinocchio's ``getFrameJacobian``, its arithmetic in its order: the same bits), each link's
Fossen wrench f_l (link frame) is formed and summed by virtual work, Mbar += sum_l J_l^T M_A,l J_l and
nbar -= sum_l J_l^T f_l (the derivation is the docstring of :mod:`uvms.dynamics.plant.plant`). Compiled, because as
numpy calls on arrays of a few rows it is about thirty calls, each dominated by the interpreter's overhead, and a
Pinocchio getter per link costs more than the link's arithmetic.

The module imports numba, so it is loaded where a plant is first evaluated; its kernel compiles at its first call
and is cached on disk (``cache=True``, see :mod:`uvms.numerics._kernels`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["frame_jacobian_into", "frame_jacobian_program", "hydro_terms_into", "pack_constants",
           "plant_terms_into"]


@njit(cache=True)
def _cross(a0: float, a1: float, a2: float, b0: float, b1: float, b2: float) -> tuple[float, float, float]:
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@njit(cache=True, inline="always")
def hydro_terms_into(jacobians: np.ndarray, v: np.ndarray, joint_bias: np.ndarray, rotations: np.ndarray,
                     motion_to_link: np.ndarray, added_mass: np.ndarray, linear: np.ndarray, forward: np.ndarray,
                     quadratic: np.ndarray, buoyancy: np.ndarray, center_of_buoyancy: np.ndarray, current: np.ndarray,
                     with_added_mass: bool,
                     with_damping: bool, with_current: bool, with_buoyancy: bool, mass: np.ndarray,
                     bias_forces: np.ndarray, with_mass: bool) -> None:
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
        with_mass: False: ``mass`` left as it is (nbar alone, each entry's operations unchanged: a second velocity at
            the same configuration, whose Mbar is the first's).
    """
    count, _, nv = jacobians.shape
    nu = np.empty(6)
    relative = np.empty(6)
    rate = np.zeros(6)  # Jdot_l v - nu_c'
    wrench = np.empty(6)
    a = np.empty(6)  # M_A nu_r
    product = np.empty((nv, 6))  # (M_A J)^T over the moved columns, row j: moved column j
    columns = np.empty(nv, dtype=np.int64)
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
            # Mbar += J^T (M_A J) over the columns J moves (its zero columns add nothing); each sum in its order
            # (from 0.0, k or i ascending; a zero entry of J adds a signed zero: the sum is unchanged), written out
            # with the column's entries in registers: independent sums the processor overlaps
            if with_mass:
                moved = 0
                for column in range(nv):
                    for row in range(6):
                        if jacobian[row, column] != 0.0:
                            columns[moved] = column
                            moved += 1
                            break
                for j in range(moved):
                    column = columns[j]
                    j0, j1, j2 = jacobian[0, column], jacobian[1, column], jacobian[2, column]
                    j3, j4, j5 = jacobian[3, column], jacobian[4, column], jacobian[5, column]
                    for i in range(6):
                        product[j, i] = (((((0.0 + inertia[i, 0] * j0) + inertia[i, 1] * j1) + inertia[i, 2] * j2)
                                          + inertia[i, 3] * j3) + inertia[i, 4] * j4) + inertia[i, 5] * j5
                for i_row in range(moved):
                    row = columns[i_row]
                    j0, j1, j2 = jacobian[0, row], jacobian[1, row], jacobian[2, row]
                    j3, j4, j5 = jacobian[3, row], jacobian[4, row], jacobian[5, row]
                    for j in range(moved):
                        mass[row, columns[j]] += (((((0.0 + j0 * product[j, 0]) + j1 * product[j, 1])
                                                    + j2 * product[j, 2]) + j3 * product[j, 3]) + j4 * product[j, 4]) \
                            + j5 * product[j, 5]
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


@njit(cache=True, inline="always")
def frame_jacobian_into(jacobian: np.ndarray, placement: np.ndarray, rotation: np.ndarray, translation: np.ndarray,
                        program: np.ndarray, out: np.ndarray, frame_rotation: np.ndarray) -> None:
    """A frame's LOCAL Jacobian (6, nv) into ``out`` from Pinocchio's world Jacobian: ``pin.getFrameJacobian``'s
    numbers (its operations in its order: oMf = oMi jMf, then each column Ad(oMf)^-1 J_k); the frame's rotation
    in the world into ``frame_rotation`` (3, 3).

    Args:
        jacobian: data.J (6, nv_extended), world, after ``computeJointJacobians``.
        placement: (4, 4) oMi of the frame's joint; rotation (3, 3), translation (3,): the frame in its joint.
        program: (P, 3) int rows (column of data.J, column of v, 1 to add / 0 to set), Pinocchio's walk up the
            joint's support (:func:`frame_jacobian_program`).
        out: (6, nv), frame_rotation: (3, 3) written.
    """
    r = frame_rotation  # read back into registers below: the writes to out need not reload it
    for i in range(3):
        for j in range(3):
            r[i, j] = placement[i, 0] * rotation[0, j] + placement[i, 1] * rotation[1, j] + \
                placement[i, 2] * rotation[2, j]
    p0 = placement[0, 3] + (placement[0, 0] * translation[0] + placement[0, 1] * translation[1]
                            + placement[0, 2] * translation[2])
    p1 = placement[1, 3] + (placement[1, 0] * translation[0] + placement[1, 1] * translation[1]
                            + placement[1, 2] * translation[2])
    p2 = placement[2, 3] + (placement[2, 0] * translation[0] + placement[2, 1] * translation[1]
                            + placement[2, 2] * translation[2])
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = r[0, 0], r[0, 1], r[0, 2], r[1, 0], r[1, 1], r[1, 2], r[2, 0], \
        r[2, 1], r[2, 2]
    out[:, :] = 0.0
    for step in range(program.shape[0]):
        source, column, add = program[step, 0], program[step, 1], program[step, 2]
        w0, w1, w2 = jacobian[3, source], jacobian[4, source], jacobian[5, source]
        l0 = jacobian[0, source] - (p1 * w2 - p2 * w1)  # v - p x w
        l1 = jacobian[1, source] - (p2 * w0 - p0 * w2)
        l2 = jacobian[2, source] - (p0 * w1 - p1 * w0)
        x0 = r00 * l0 + r10 * l1 + r20 * l2
        x1 = r01 * l0 + r11 * l1 + r21 * l2
        x2 = r02 * l0 + r12 * l1 + r22 * l2
        y0 = r00 * w0 + r10 * w1 + r20 * w2
        y1 = r01 * w0 + r11 * w1 + r21 * w2
        y2 = r02 * w0 + r12 * w1 + r22 * w2
        if add:
            out[0, column] += x0
            out[1, column] += x1
            out[2, column] += x2
            out[3, column] += y0
            out[4, column] += y1
            out[5, column] += y2
        else:
            out[0, column] = x0
            out[1, column] = x1
            out[2, column] = x2
            out[3, column] = y0
            out[4, column] = y1
            out[5, column] = y2


def frame_jacobian_program(model, data, joint: int) -> np.ndarray:
    """The (P, 3) rows :func:`frame_jacobian_into` walks for a frame on ``joint``: Pinocchio's own walk (its
    non-mimic columns set, then its mimic columns added: a mimic joint moves its driver's column of v).

    Args:
        model, data: the Pinocchio model and a data of it (its column tables).
    """
    first = model.idx_vExtendeds[joint]
    last = first + model.nvExtendeds[joint] - 1
    supports = model.mimic_joint_supports[joint]
    mimic = len(supports) > 0 and supports[-1] == joint
    rows = []
    column = data.non_mimic_parents_fromRow[first] if mimic else last
    while column >= 0:
        rows.append((column, data.idx_vExtended_to_idx_v_fromRow[column], 0))
        column = data.non_mimic_parents_fromRow[column]
    column = last if mimic else data.mimic_parents_fromRow[first]
    while column >= 0:
        rows.append((column, data.idx_vExtended_to_idx_v_fromRow[column], 1))
        column = data.mimic_parents_fromRow[column]
    return np.array(rows, dtype=np.int64).reshape(-1, 3)


def pack_constants(slots: np.ndarray, programs: np.ndarray, starts: np.ndarray, flags: np.ndarray,
                   link_rotations: np.ndarray, link_translations: np.ndarray, motion_to_link: np.ndarray,
                   added_mass: np.ndarray, linear: np.ndarray, forward: np.ndarray, quadratic: np.ndarray,
                   buoyancy: np.ndarray, center_of_buoyancy: np.ndarray, current: np.ndarray) -> tuple[np.ndarray,
                                                                                                     np.ndarray]:
    """The plant's constants for :func:`plant_terms_into` as two flat arrays (ints, floats): two arguments instead
    of fourteen (numba's dispatch checks each argument's type at every call); the kernel reads them back as views.

    Args:
        slots: (L,) each link's joint (its row of the joints' arrays); programs: (P, 3) the links' walks
            (:func:`frame_jacobian_program`), link l's rows starts[l]:starts[l + 1] (starts (L + 1,));
        flags: (4,) added mass, damping, current, buoyancy on (1) or off (0);
        link_rotations, link_translations: (L, 3, 3), (L, 3) the links in their joints; motion_to_link ...
            center_of_buoyancy, current: the stacked link constants (:func:`hydro_terms_into`).
    """
    count = len(slots)
    ints = np.concatenate([[count, len(programs)], slots, starts, np.ravel(programs), flags]).astype(np.int64)
    floats = np.concatenate([np.ravel(x) for x in (link_rotations, link_translations, motion_to_link, added_mass,
                                                    linear, forward, quadratic, buoyancy, center_of_buoyancy,
                                                    current)]).astype(float)  # 106 L + 3 numbers
    return ints, floats


@njit(cache=True, inline="always")
def plant_terms_into(upper: np.ndarray, h: np.ndarray, jacobian: np.ndarray, placements: np.ndarray,
                     accelerations: np.ndarray, v: np.ndarray, mass: np.ndarray, bias_forces: np.ndarray,
                     ints: np.ndarray, floats: np.ndarray, with_mass: bool) -> None:
    """Mbar and nbar of the plant in one call: the links' LOCAL Jacobians from Pinocchio's world Jacobian
    (:func:`frame_jacobian_into`), then :func:`hydro_terms_into` on Pinocchio's M (its upper triangle, as crba
    fills it) and h.

    Args:
        upper: M (nv, nv), its upper triangle read; h: (nv,) rnea's bias forces.
        jacobian: data.J (6, nv_extended), world; placements: (njoints, 12) every joint's oMi, its rotation
            column-major then its translation; accelerations: (njoints, 6) their bias accelerations (data.a, a = 0;
            read with the added mass) (:class:`uvms.dynamics.plant.data_views.JointArrays`: views of Pinocchio's
            data).
        v: (nv,); mass: Mbar (nv, nv) out; bias_forces: nbar (nv,) out.
        ints, floats: the plant's constants (:func:`pack_constants`).
        with_mass: False: nbar alone, ``mass`` and ``upper`` not read (:func:`hydro_terms_into`).
    """
    nv = h.shape[0]
    for row in range(nv):
        bias_forces[row] = h[row]
        if with_mass:
            for column in range(nv):
                mass[row, column] = upper[row, column] if column >= row else upper[column, row]
    count, steps = ints[0], ints[1]
    if count == 0:
        return
    slots = ints[2:2 + count]
    starts = ints[2 + count:3 + 2 * count]
    programs = ints[3 + 2 * count:3 + 2 * count + 3 * steps].reshape(steps, 3)
    flags = ints[3 + 2 * count + 3 * steps:]
    link_rotations = floats[:9 * count].reshape(count, 3, 3)
    link_translations = floats[9 * count:12 * count].reshape(count, 3)
    motion_to_link = floats[12 * count:48 * count].reshape(count, 6, 6)
    added_mass = floats[48 * count:84 * count].reshape(count, 6, 6)
    linear = floats[84 * count:90 * count].reshape(count, 6)
    forward = floats[90 * count:96 * count].reshape(count, 6)
    quadratic = floats[96 * count:102 * count].reshape(count, 6)
    buoyancy = floats[102 * count:103 * count]
    center_of_buoyancy = floats[103 * count:106 * count].reshape(count, 3)
    current = floats[106 * count:]
    jacobians = np.empty((count, 6, nv))
    rotations = np.empty((count, 3, 3))  # the links' in the world
    joint_bias = np.zeros((count, 6))
    placement = np.zeros((4, 4))  # the joint's oMi as frame_jacobian_into reads it (its last row unread)
    with_added_mass = flags[0] != 0
    for link in range(count):
        slot = slots[link]
        for i in range(3):
            placement[i, 3] = placements[slot, 9 + i]
            for k in range(3):
                placement[i, k] = placements[slot, i + 3 * k]
        frame_jacobian_into(jacobian, placement, link_rotations[link], link_translations[link],
                            programs[starts[link]:starts[link + 1]], jacobians[link], rotations[link])
        if with_added_mass:
            joint_bias[link] = accelerations[slot]
    hydro_terms_into(jacobians, v, joint_bias, rotations, motion_to_link, added_mass, linear, forward, quadratic,
                     buoyancy, center_of_buoyancy, current, with_added_mass, flags[1] != 0, flags[2] != 0,
                     flags[3] != 0, mass, bias_forces, with_mass)
