"""The plant's equations of motion around the hydrodynamic pass, in the same compiled call, and the actuated plant's
per-step numbers: a body wrench's generalized force, the motors' accelerations, the vehicle's right-hand side, the
motor torques, the thrusters' wrench, lag and saturation, the state's finiteness, the rows' powers.

:meth:`uvms.dynamics.plant.plant.Plant.stage_acceleration`, ``ActuatedPlantSystem._rate`` (the plant's
:class:`~uvms.dynamics.plant.compiled.CompiledPass`): after Pinocchio's algorithms one call forms Mbar and nbar
(:func:`.hydro.plant_terms_into`), subtracts J_base^T w of a wrench w on the vehicle (the base frame's LOCAL Jacobian
from data.J as ``pin.getFrameJacobian`` forms it), the motors' a_m = (u - qd_m) / tau, the vehicle's right-hand side
Mbar_bm a_m + nbar_b and its 6 x 6 (3 x 3 planar) solve with numpy's LAPACK (:mod:`.solve`; numba's own solve calls
SciPy's, whose numbers differ). :func:`vehicle_terms_wrench_into`: a floating vehicle's inverse dynamics (and nbar
at a second velocity); :func:`actuation_rows`: a run's wrench and powers. One kernel serves each kind of call (the
stages' rate and the sample's dynamics, the inverse dynamics with or without a second velocity): every kernel loaded
from the cache costs a run ~1 ms per 20 kB of its code, and these carry the plant's whole pass.

Every number is the one the numpy expressions it replaces gave, bit for bit: elementwise arithmetic in their order
(numba contracts nothing without ``fastmath``), products through ``np.dot`` on arrays in the layout numpy held them
(C- or column-major), which calls the BLAS routine numpy's ``@`` calls (a product with a single output entry as numpy
computes it: a dot product), numpy's pairwise sums and clip written out.

Loaded (numba) where a plant is first evaluated; compiled at the first call, cached (:mod:`uvms.numerics._kernels`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .dense import clip_into
from .hydro import frame_jacobian_into, frame_jacobian_program, pack_constants, plant_terms_into
from .pose import inverse_action_into
from .solve import solve_into
from .vehicle import vehicle_wrench_into

__all__ = ["accelerations_into", "actuated_rate_into", "actuation_rows", "all_finite", "clipped",
           "finite_clipped_into", "motor_torques_into", "numpy_product_into", "plant_constants", "terms_into",
           "thrusters_into", "vehicle_terms_wrench_into"]


@njit(cache=True, inline="always")
def numpy_product_into(matrix: np.ndarray, vector: np.ndarray, out: np.ndarray) -> None:
    """out = matrix @ vector (matrix (r, c) C- or F-contiguous, as numpy held it) as numpy's ``@`` gives it:
    BLAS's gemv on that layout, or its dot product for a single row (what numpy calls there)."""
    if matrix.shape[0] == 1:
        out[0] = np.dot(np.ascontiguousarray(matrix[0]), vector)
    elif matrix.shape[0] > 0:
        np.dot(matrix, vector, out)


@njit(cache=True)
def terms_into(upper: np.ndarray, h: np.ndarray, jacobian: np.ndarray, placements: np.ndarray,
               accelerations: np.ndarray, ints: np.ndarray, floats: np.ndarray, v: np.ndarray, wrench: np.ndarray,
               mass: np.ndarray, bias_forces: np.ndarray) -> None:
    """Mbar (nv, nv) and nbar (nv,) into ``mass`` and ``bias_forces``: :func:`plant_terms_into`, then nbar -=
    J_base^T w for a wrench w (6,) [N, N m] on the vehicle, FLU at its base frame (none: w of size 0).

    Args:
        upper, h, jacobian, placements, accelerations: Pinocchio's, as :func:`plant_terms_into` reads them;
        ints, floats: the plant's constants, the hydrodynamic pass's (:func:`.hydro.pack_constants`) followed by
            this module's (:func:`plant_constants`); v: (nv,); wrench: (6,) or (0,).
    """
    hydro_ints, hydro_floats = _hydro_sizes(ints)
    plant_terms_into(upper, h, jacobian, placements, accelerations, v, mass, bias_forces, ints[:hydro_ints],
                     floats[:hydro_floats], True)
    if wrench.size:
        stage_ints, stage_floats = ints[hydro_ints:], floats[hydro_floats:]
        steps, slot = stage_ints[1], stage_ints[2]
        placement = np.zeros((4, 4))
        for i in range(3):
            placement[i, 3] = placements[slot, 9 + i]
            for k in range(3):
                placement[i, k] = placements[slot, i + 3 * k]
        # row-major, as getFrameJacobian returns it (a C-ordered copy): numpy's w @ J called BLAS on that layout
        base = np.empty((6, h.shape[0]))
        rotation = np.empty((3, 3))
        frame_jacobian_into(jacobian, placement, stage_floats[1:10].copy().reshape(3, 3), stage_floats[10:13],
                            stage_ints[3:3 + 3 * steps].copy().reshape(steps, 3), base, rotation)
        product = np.dot(wrench, base)  # numpy's w @ J (nv > 1 columns: BLAS's gemv)
        for i in range(h.shape[0]):
            bias_forces[i] -= product[i]


@njit(cache=True)
def vehicle_terms_wrench_into(upper: np.ndarray, h: np.ndarray, jacobian: np.ndarray, placements: np.ndarray,
                              accelerations: np.ndarray, ints: np.ndarray, floats: np.ndarray, v: np.ndarray,
                              mass: np.ndarray, bias_forces: np.ndarray, base_acceleration: np.ndarray,
                              arm_acceleration: np.ndarray, rotation: np.ndarray, translation: np.ndarray,
                              base_frame: bool, out: np.ndarray, second_h: np.ndarray, second_accelerations: np.ndarray,
                              second_v: np.ndarray, second_bias_forces: np.ndarray) -> None:
    """:func:`terms_into` (no wrench on the vehicle), then the vehicle rows' body wrench at the base frame
    (:func:`.vehicle.vehicle_wrench_into`) into ``out`` (6,): a floating vehicle's inverse dynamics in one call; with
    a second velocity ``second_v`` (nv,; size 0: none), nbar there at the same q into ``second_bias_forces`` (from
    rnea's ``second_h`` and the joints' ``second_accelerations`` at it; M and the links' Jacobians are the first's):
    the controller's observer and its feedforward's terms at one configuration.

    Args:
        upper ... v, mass, bias_forces: as :func:`terms_into`; base_acceleration ... out: as
            :func:`.vehicle.vehicle_wrench_into`.
    """
    terms_into(upper, h, jacobian, placements, accelerations, ints, floats, v, np.zeros(0), mass, bias_forces)
    vehicle_wrench_into(mass, bias_forces, base_acceleration, arm_acceleration, rotation, translation, base_frame, out)
    if second_v.size:
        hydro_ints, hydro_floats = _hydro_sizes(ints)
        plant_terms_into(upper, second_h, jacobian, placements, second_accelerations, second_v, mass,
                         second_bias_forces, ints[:hydro_ints], floats[:hydro_floats], False)


@njit(cache=True)
def accelerations_into(upper: np.ndarray, h: np.ndarray, jacobian: np.ndarray, placements: np.ndarray,
                       accelerations: np.ndarray, ints: np.ndarray, floats: np.ndarray, v: np.ndarray,
                       command: np.ndarray, wrench: np.ndarray, mass: np.ndarray, bias_forces: np.ndarray,
                       acceleration: np.ndarray, torque: np.ndarray) -> bool:
    """:func:`terms_into`, then v' (nv,) into ``acceleration``: the motors' a_m, then the vehicle's a_b =
    -solve(Mbar_bb, rhs) with numpy's LAPACK (:func:`.solve.solve_into`); then, when ``torque`` has entries, the motor
    torques of v' (:func:`motor_torques_into`): an integrator's stage, or the dynamics a step's record keeps.

    a_m = (u - qd_m) / tau (numpy's ``np.subtract(u, v[nb:]); /= tau``), rhs = Mbar_bm a_m + nbar_b (``mass[:nb,
    nb:] @ a_m; += nbar[:nb]``).

    Args:
        upper ... wrench, mass, bias_forces: as :func:`terms_into`; command: u (n_arm,) [rad/s or m/s].
        acceleration: v' (nv,) written; torque: (n_arm,) written, or (0,) (none asked).

    Returns:
        False when the vehicle's block is singular or a_b not finite (``acceleration`` is then not the rate,
        ``torque`` not written).
    """
    terms_into(upper, h, jacobian, placements, accelerations, ints, floats, v, wrench, mass, bias_forces)
    hydro_ints, hydro_floats = _hydro_sizes(ints)
    nb, tau = ints[hydro_ints], floats[hydro_floats]
    nv = v.shape[0]
    arm = np.empty(nv - nb)
    for i in range(nv - nb):
        arm[i] = (command[i] - v[nb + i]) / tau
        acceleration[nb + i] = arm[i]
    rhs = np.zeros(nb)  # numpy's product over no column: zeros
    if nv > nb:
        numpy_product_into(np.ascontiguousarray(mass[:nb, nb:]), arm, rhs)
    for i in range(nb):
        rhs[i] += bias_forces[i]
    base = np.empty(nb)
    if not solve_into(mass[:nb, :nb], rhs, base):
        return False
    for i in range(nb):
        acceleration[i] = -base[i]
    if torque.size:
        motor_torques_into(mass, acceleration, bias_forces, nb, torque)
    return True


@njit(cache=True)
def actuated_rate_into(upper: np.ndarray, h: np.ndarray, jacobian: np.ndarray, placements: np.ndarray,
                       accelerations: np.ndarray, ints: np.ndarray, floats: np.ndarray, x: np.ndarray,
                       command: np.ndarray, thrust_command: np.ndarray, matrix: np.ndarray,
                       time_constants: np.ndarray, extra: np.ndarray, wrench: np.ndarray, mass: np.ndarray,
                       bias_forces: np.ndarray, rate: np.ndarray, torque: np.ndarray) -> bool:
    """An actuated plant's rate at its state x = [v (nv,), f (n,), ...] but the base acceleration: the thrusters'
    wrench and lag (:func:`thrusters_into`), plus ``extra`` (the fins' wrench, or size 0), then
    :func:`accelerations_into` under that wrench, then, when ``torque`` has entries, the motor torques of its v'
    (:func:`motor_torques_into`): a stage's rate, or the rate and the dynamics a step's record keeps, in one call.

    Args:
        upper ... floats: as :func:`terms_into`; x: the state's vector part; command: u (n_arm,);
        thrust_command: sat(f_cmd) (n,) [N]; matrix: B (6, n); time_constants: (n,) [s]; extra: (6,) or (0,).
        wrench: (6,) written: B f (+ extra); mass, bias_forces: Mbar, nbar written; rate: (len(x),), its v' and f'
            written (the rest: the caller's); torque: (n_arm,) written, or (0,) (none asked).

    Returns:
        False as :func:`accelerations_into` (``torque`` then not written).
    """
    nv, n = h.shape[0], h.shape[0] + matrix.shape[1]
    thrusters_into(matrix, x[nv:n], thrust_command, time_constants, wrench, rate[nv:n])
    if extra.size:
        for i in range(6):
            wrench[i] += extra[i]
    return accelerations_into(upper, h, jacobian, placements, accelerations, ints, floats, x[:nv], command, wrench,
                              mass, bias_forces, rate[:nv], torque)


@njit(cache=True, inline="always")
def motor_torques_into(mass: np.ndarray, acceleration: np.ndarray, bias_forces: np.ndarray, nb: int,
                       torque: np.ndarray) -> None:
    """tau_m (n_arm,) [N m or N] = (Mbar_mb a_b + Mbar_mm a_m) + nbar_m into ``torque``, summed in this order
    (numpy's ``mass[nb:, :nb] @ a[:nb]; += mass[nb:, nb:] @ a[nb:]; += nbar[nb:]``)."""
    nv = acceleration.shape[0]
    if nv == nb:
        return
    numpy_product_into(np.ascontiguousarray(mass[nb:, :nb]), acceleration[:nb].copy(), torque)
    arm = np.empty(nv - nb)
    numpy_product_into(np.ascontiguousarray(mass[nb:, nb:]), acceleration[nb:].copy(), arm)
    for i in range(nv - nb):
        torque[i] += arm[i]
        torque[i] += bias_forces[nb + i]


@njit(cache=True, inline="always")
def thrusters_into(matrix: np.ndarray, thrusts: np.ndarray, command: np.ndarray, time_constants: np.ndarray,
                   wrench: np.ndarray, rate: np.ndarray) -> None:
    """The thrusters' wrench B f (6,) [N, N m] into ``wrench`` (numpy's ``B @ f``) and their lag's rate
    f' = (sat(f_cmd) - f) / tau (n,) [N/s] into ``rate``.

    Args:
        matrix: B (6, n) C- or F-contiguous; thrusts: f (n,) [N]; command: sat(f_cmd) (n,) [N];
        time_constants: (n,) [s].
    """
    numpy_product_into(matrix, thrusts, wrench)
    for i in range(thrusts.shape[0]):
        rate[i] = (command[i] - thrusts[i]) / time_constants[i]


@njit(cache=True)
def all_finite(q: np.ndarray, x: np.ndarray) -> bool:
    """Whether every entry of q and x is finite (numpy's ``isfinite(q).all() and isfinite(x).all()``)."""
    for value in q:
        if not np.isfinite(value):
            return False
    for value in x:
        if not np.isfinite(value):
            return False
    return True


@njit(cache=True)
def clipped(values: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """``np.clip(values, lower, upper)`` (n,): numpy's max-then-min per entry, its comparisons (a NaN kept; an entry
    equal to a bound, a signed zero among them, gives the bound), the same bits."""
    out = np.empty(values.shape[0])
    clip_into(values, lower, upper, out)
    return out


@njit(cache=True)
def finite_clipped_into(arm: np.ndarray, thrust: np.ndarray, lower: np.ndarray, upper: np.ndarray,
                        saturated: np.ndarray) -> bool:
    """Whether the arm's and the thrusters' commands (n_arm,), (n,) are finite (:func:`all_finite`); if so the
    thrust command clipped to [lower, upper] (n,) [N] (:func:`clipped`'s numbers) into ``saturated`` (n,): an actuated
    plant's command checked and saturated in one call."""
    if not all_finite(arm, thrust):
        return False
    clip_into(thrust, lower, upper, saturated)
    return True


@njit(cache=True)
def _block_sum(values: np.ndarray, start: int, count: int) -> float:
    """numpy's pairwise sum of values[start:start + count], count <= 128: a plain loop below 8 entries, else eight
    partial sums."""
    if count < 8:
        total = 0.0
        for i in range(start, start + count):
            total += values[i]
        return total
    partial = values[start:start + 8].copy()
    i = 8
    while i < count - count % 8:
        for j in range(8):
            partial[j] += values[start + i + j]
        i += 8
    total = ((partial[0] + partial[1]) + (partial[2] + partial[3])) + \
        ((partial[4] + partial[5]) + (partial[6] + partial[7]))
    for k in range(i, count):
        total += values[start + k]
    return total


@njit(cache=True)
def _numpy_sum(values: np.ndarray) -> float:
    """numpy's ``values.sum()`` (its pairwise summation: blocks of at most 128 entries, longer runs halved at a
    multiple of 8 and the halves' sums added), the same bits; the halving walked with a stack (numba's on-disk cache
    does not take a recursive kernel)."""
    if values.shape[0] <= 128:
        return _block_sum(values, 0, values.shape[0])
    starts, counts = np.empty(128, dtype=np.int64), np.empty(128, dtype=np.int64)
    stages, sums = np.zeros(128, dtype=np.int64), np.empty(128)
    starts[0], counts[0], top, done = 0, values.shape[0], 0, 0
    while top >= 0:
        half = counts[top] // 2
        half -= half % 8
        if counts[top] <= 128:  # a block: its sum onto the stack of sums
            sums[done] = _block_sum(values, starts[top], counts[top])
            done, top = done + 1, top - 1
        elif stages[top] == 0:  # the first half next
            stages[top] = 1
            starts[top + 1], counts[top + 1], stages[top + 1] = starts[top], half, 0
            top += 1
        elif stages[top] == 1:  # then the second
            stages[top] = 2
            starts[top + 1], counts[top + 1], stages[top + 1] = starts[top] + half, counts[top] - half, 0
            top += 1
        else:  # both halves summed: first + second
            sums[done - 2] = sums[done - 2] + sums[done - 1]
            done, top = done - 1, top - 1
    return sums[0]


@njit(cache=True)
def _base_twist_into(v: np.ndarray, nb: int, rotation: np.ndarray, translation: np.ndarray,
                     twist: np.ndarray) -> None:
    """The vehicle's body twist (6,) in its base frame from the velocity v (nv,) into ``twist``:
    ``base_placement.actInv(pin.Motion(...))`` as Pinocchio computes it (:func:`~.pose.inverse_action_into`), the
    same bits; a planar vehicle's (vx, vy, wz) as the motion (vx, vy, 0, 0, 0, wz).

    Args:
        rotation (3, 3), translation (3,) [m]: the base frame in the vehicle joint's frame (joint_M_base).
    """
    if nb == 6:
        inverse_action_into(rotation, translation, v[:3], v[3:6], twist, 0, 3)
    else:  # the planar motion (vx, vy, 0; 0, 0, wz)
        inverse_action_into(rotation, translation, np.array([v[0], v[1], 0.0]), np.array([0.0, 0.0, v[2]]), twist,
                            0, 3)


@njit(cache=True)
def actuation_rows(matrix: np.ndarray, thrusts: np.ndarray, v: np.ndarray, joint_torque: np.ndarray,
                   fins: np.ndarray, nb: int, rotation: np.ndarray,
                   translation: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """What an actuated run's rows hold of the thrusters and motors, from the stored rows, each row's numbers those
    the numpy expressions gave per row: (body wrench (N, 6) B f + the fins' wrench, or B f + 0.0 without fins
    (numpy's sum with their zero wrench: signed zeros made positive); thrust power (N,) sum_i f_i (B_i . nu) [W] and
    its absolute sum (N,) [W] (numpy's pairwise sums), nu the body twist; motor power (N,) tau_m . qd_m [W]).

    Args:
        matrix: B (6, n) column-major (B^T row-major); thrusts: f (N, n) [N]; v: (N, nv); joint_torque: tau_m
            (N, n_arm); fins: their wrench (N, 6), or (0, 6) without fins; nb: 6 (3 planar); rotation (3, 3),
            translation (3,): the base frame in the vehicle joint's frame.
    """
    rows, count = thrusts.shape
    wrench, thrust_power = np.empty((rows, 6)), np.empty(rows)
    absolute, motor = np.empty(rows), np.empty(rows)
    thrust, twist, pushed = np.empty(count), np.empty(6), np.empty(6)
    speeds, powers, magnitudes = np.empty(count), np.empty(count), np.empty(count)
    for k in range(rows):
        thrust[:] = thrusts[k]
        numpy_product_into(matrix, thrust, pushed)  # numpy's B @ f
        for i in range(6):
            wrench[k, i] = pushed[i] + (fins[k, i] if fins.shape[0] else 0.0)
        _base_twist_into(v[k], nb, rotation, translation, twist)
        numpy_product_into(matrix.T, twist, speeds)  # numpy's B.T @ nu
        for i in range(count):
            powers[i] = thrust[i] * speeds[i]
            magnitudes[i] = abs(powers[i])
        thrust_power[k], absolute[k] = _numpy_sum(powers), _numpy_sum(magnitudes)
        arm = joint_torque.shape[1]
        motor[k] = np.dot(joint_torque[k].copy(), v[k, nb:].copy()) if arm else 0.0
    return wrench, thrust_power, absolute, motor


def plant_constants(model, data, stacked, flags: np.ndarray, current: np.ndarray, nb: int, base_frame,
                    motor_time_constant: float) -> tuple[np.ndarray, np.ndarray]:
    """A plant's constants (ints, floats) for this module's kernels: the hydrodynamic pass's
    (:func:`.hydro.pack_constants`: the links' walks over data.J and their stacked parameters), then the vehicle's
    velocity size, the base frame's joint and walk, the motors' time constant and the base frame in its joint.

    Args:
        model, data: the plant's Pinocchio model and kinematic data; stacked: its
            :class:`~uvms.dynamics.plant.added_mass.StackedLinks`; flags: (4,) added mass, damping, current, buoyancy
            on (1) or off (0); current: (3,) [m/s] world; nb: 6 (3 planar); base_frame: the vehicle's root link's
            ``pin.Frame``; motor_time_constant: tau [s].
    """
    walks = [frame_jacobian_program(model, data, joint) for joint in stacked.joints]
    starts = np.cumsum([0] + [len(walk) for walk in walks]).astype(np.int64)
    programs = np.concatenate(walks) if walks else np.zeros((0, 3), dtype=np.int64)
    ints, floats = pack_constants(
        np.array(stacked.joints, dtype=np.int64), programs, starts, flags, stacked.rotations, stacked.translations,
        stacked.motion_to_link, stacked.added_mass, stacked.linear_damping, stacked.forward_damping,
        stacked.quadratic_damping, stacked.buoyancy, stacked.center_of_buoyancy, current)
    joint = base_frame.parentJoint
    base = frame_jacobian_program(model, data, joint)
    stage_ints = np.concatenate([[nb, len(base), joint], np.ravel(base)]).astype(np.int64)
    stage_floats = np.concatenate([[motor_time_constant], np.ravel(base_frame.placement.rotation),
                                   np.ravel(base_frame.placement.translation)]).astype(float)
    return np.concatenate([ints, stage_ints]), np.concatenate([floats, stage_floats])


@njit(cache=True)
def _hydro_sizes(ints: np.ndarray) -> tuple[int, int]:
    """How many ints and floats the hydrodynamic pass's constants take (the layout of :func:`.hydro.pack_constants`)."""
    count, steps = ints[0], ints[1]
    return 3 + 2 * count + 3 * steps + 4, 106 * count + 3
