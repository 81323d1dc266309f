"""Compiled dense kernels of the solvers' inner loops (numba, nopython mode).

A hot loop's step is a handful of products of (6, nv) matrices, a (k, k) Cholesky solve and a few
vector updates. Each numpy call costs 0.3-1 us of interpreter and dispatch overhead on arrays this
small, about what the arithmetic itself costs, so a step written as numpy calls is bounded by their
number. Here the whole dense part of a step is one compiled call; Pinocchio still computes every pose,
Jacobian, logarithm and integration.

The module imports numba, so it is loaded where a solver first uses it, not by ``import uvms``. The
kernels compile at their first call and are cached on disk beside this file (or in numba's user cache
when the package folder is read-only): the first solve after an install or an edit of this file compiles
the kernels it calls (about 3.5 s for the CLIK's, 7 s for the set-based solver's); every later process
loads the machine code (numba's import and first call, about 0.5-1 s together). Products, scalings and
copies are written as loops: numba's BLAS binding and its broadcasting slice assignment cost seconds of
compilation each, and at (6, nv) sizes the loops are as fast.
"""

from __future__ import annotations

import numpy as np
from numba import njit

#: Sweeps after which a one-sided Jacobi SVD that has not converged is refused (finite input needs about six).
JACOBI_SWEEPS = 64
EPSILON = np.finfo(np.float64).eps

__all__ = ["JACOBI_SWEEPS", "activation_reference_into", "bell_into", "bell_value", "cholesky_solve_in_place",
           "clik_solution_into", "decompose", "dls_pose_velocity", "dls_solve_into", "icat_into", "inside_box",
           "joint_limit_motion_into", "level_inverse_into", "orthogonalize_rows", "pose_error_norm", "project_into_box",
           "rate_bounds_into", "rotation_to_target", "scale_lowest_first_into", "svd_inverse_into",
           "variable_damping_value", "velocity_box_into", "weighted_inverse_into"]


@njit(cache=True)
def variable_damping_value(sigma_min: float, epsilon: float, lambda_max: float) -> float:
    """Damping l of amundsen2018 eq. 6: l^2 = (1 - (sigma_min / epsilon)^2) lambda_max^2 below epsilon, else 0."""
    if sigma_min >= epsilon:
        return 0.0
    return np.sqrt(1.0 - (sigma_min / epsilon) ** 2) * lambda_max


@njit(cache=True)
def zero_negligible_row(rows: np.ndarray, row: int) -> None:
    """Set row ``row`` of B to exact zeros (its norm is at the rounding level of the matrix)."""
    for col in range(rows.shape[1]):
        rows[row, col] = 0.0


@njit(cache=True)
def orthogonalize_rows(rows: np.ndarray, rotation: np.ndarray) -> bool:
    """One-sided (Hestenes) Jacobi SVD: rotate the rows of B (k, n) in place until they are mutually orthogonal.

    On return B_out = G B_in with G (k, k) orthogonal (written to ``rotation``): the row norms of B_out are the
    singular values and B_in = G^T B_out. Pairs are rotated until |b_i . b_j| <= n eps |b_i| |b_j|, which gives
    the singular values to high relative accuracy (Demmel and Veselic 1992). A row whose norm falls to the
    rounding level of the matrix (n eps |B|_F) is set to zero: its direction is noise that no rotation can
    make orthogonal, and its singular value is zero to working precision.

    Returns:
        False when the rows are not orthogonal after ``JACOBI_SWEEPS`` sweeps (non-finite input).
    """
    count, length = rows.shape
    for row in range(count):
        for col in range(count):
            rotation[row, col] = 1.0 if row == col else 0.0
    tolerance = length * EPSILON
    frobenius_squared = 0.0
    for row in range(count):
        for col in range(length):
            frobenius_squared += rows[row, col] * rows[row, col]
    if frobenius_squared != frobenius_squared or frobenius_squared == np.inf:  # NaN or an infinite entry
        return False
    negligible = tolerance * tolerance * frobenius_squared  # a squared row norm at the rounding level
    for _ in range(JACOBI_SWEEPS):
        rotated = False
        for first in range(count - 1):
            for second in range(first + 1, count):
                alpha = beta = gamma = 0.0
                for col in range(length):
                    a, b = rows[first, col], rows[second, col]
                    alpha += a * a
                    beta += b * b
                    gamma += a * b
                if alpha <= negligible or beta <= negligible:
                    zero_negligible_row(rows, first if alpha <= negligible else second)
                    continue
                if not abs(gamma) > tolerance * np.sqrt(alpha) * np.sqrt(beta):
                    continue
                rotated = True
                zeta = (beta - alpha) / (2.0 * gamma)
                tangent = (1.0 if zeta >= 0.0 else -1.0) / (abs(zeta) + np.sqrt(1.0 + zeta * zeta))
                cosine = 1.0 / np.sqrt(1.0 + tangent * tangent)
                sine = cosine * tangent
                for col in range(length):
                    a, b = rows[first, col], rows[second, col]
                    rows[first, col] = cosine * a - sine * b
                    rows[second, col] = sine * a + cosine * b
                for col in range(count):
                    a, b = rotation[first, col], rotation[second, col]
                    rotation[first, col] = cosine * a - sine * b
                    rotation[second, col] = sine * a + cosine * b
        if not rotated:
            return True
    return False


@njit(cache=True)
def decompose(matrix: np.ndarray, damping: float, epsilon: float, lambda_max: float, rcond: float,
              floor: float):
    """The SVD of A (k, n) as the inverse needs it: (converged, wide, B, G, factors, sigma_min, l used).

    B = G A (rows s_i v_i^T) when k <= n (``wide``), else B = G A^T (rows s_i u_i^T); factors (m,) are
    1 / (s_i^2 + l^2), or with l = 0 1 / s_i^2 above rcond * s_max and 0 below, and 0 for s_i <= ``floor`` (an
    absolute noise level, 0: none), so that
    A^+ = B^T diag(factors) G (wide) or G^T diag(factors) B (tall): right^T diag(factors) left. sigma_min is 0
    when k > n; l is the fixed ``damping``, or the variable damping of sigma_min when ``epsilon`` > 0.
    """
    rows, columns = matrix.shape
    wide = rows <= columns
    work = matrix.copy() if wide else matrix.T.copy()  # (m, p), m <= p
    count, length = work.shape
    rotation = np.empty((count, count))
    factors = np.zeros(count)
    if not orthogonalize_rows(work, rotation):
        return False, wide, work, rotation, factors, np.nan, np.nan
    singular = np.empty(count)
    largest, smallest = 0.0, np.inf
    for row in range(count):
        value = 0.0
        for col in range(length):
            value += work[row, col] * work[row, col]
        singular[row] = np.sqrt(value)
        largest = max(largest, singular[row])
        smallest = min(smallest, singular[row])
    sigma_min = smallest if wide and count > 0 else 0.0
    used = variable_damping_value(sigma_min, epsilon, lambda_max) if epsilon > 0.0 else damping
    for row in range(count):
        if singular[row] <= floor and floor > 0.0:
            continue  # rounding noise: its direction is no direction
        if used > 0.0:
            factors[row] = 1.0 / (singular[row] * singular[row] + used * used)
        elif singular[row] > rcond * largest:
            factors[row] = 1.0 / (singular[row] * singular[row])
    return True, wide, work, rotation, factors, sigma_min, used


@njit(cache=True)
def svd_inverse_into(jacobian: np.ndarray, damping: float, epsilon: float, lambda_max: float, rcond: float,
                     floor: float, out: np.ndarray) -> tuple[bool, float, float]:
    """The DLS inverse V diag(s / (s^2 + l^2)) U^T (n, k) of J (k, n) from its SVD, with sigma_min and l.

    The SVD is a one-sided Jacobi on the rows of J (of J^T when k > n), so the inverse is formed as
    B^T diag(1 / (s^2 + l^2)) G with B = G J (rows s_i v_i^T): no squared condition number. With l = 0,
    singular values below rcond * s_max count as zero (the pseudo-inverse).

    Args:
        jacobian: J (k, n).
        damping: a fixed l >= 0 (used when ``epsilon`` is 0).
        epsilon, lambda_max: the variable damping of amundsen2018 eq. 6 when epsilon > 0.
        rcond: with l = 0, the relative cut-off of singular values (``uvms.numerics.inverses.RCOND``).
        floor: singular values at or below it count as zero, damped or not (0: none).
        out: (n, k) written with the inverse.

    Returns:
        (converged (False for a non-finite J), sigma_min (0 when k > n), l used).
    """
    converged, wide, work, rotation, factors, sigma_min, used = decompose(jacobian, damping, epsilon, lambda_max,
                                                                          rcond, floor)
    if not converged:
        return False, sigma_min, used
    left, right = (rotation, work) if wide else (work, rotation)  # A^+ = right^T diag(factors) left
    out[:, :] = 0.0
    for row in range(left.shape[0]):
        if factors[row] == 0.0:
            continue
        for i in range(right.shape[1]):  # out += right_i^T f left_i
            weighted = right[row, i] * factors[row]
            for j in range(left.shape[1]):
                out[i, j] += weighted * left[row, j]
    return True, sigma_min, used


@njit(cache=True)
def product(left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """left @ right (m, n) of (m, k) and (k, n) in loops (numba's BLAS binding takes a second to compile)."""
    rows, inner = left.shape
    out = np.zeros((rows, right.shape[1]))
    for row in range(rows):
        for k in range(inner):
            value = left[row, k]
            for col in range(right.shape[1]):
                out[row, col] += value * right[k, col]
    return out


@njit(cache=True)
def apply(matrix: np.ndarray, vector: np.ndarray) -> np.ndarray:
    """matrix @ vector (m,) of (m, k) and (k,) in loops."""
    out = np.zeros(matrix.shape[0])
    for row in range(matrix.shape[0]):
        total = 0.0
        for k in range(matrix.shape[1]):
            total += matrix[row, k] * vector[k]
        out[row] = total
    return out


@njit(cache=True)
def scale_matrix(matrix: np.ndarray, scale: np.ndarray, rows: bool) -> np.ndarray:
    """diag(scale) matrix (``rows``: row i times scale[i]) or matrix diag(scale) (column j times scale[j]),
    (m, n), a new array."""
    out = np.empty(matrix.shape)
    for row in range(matrix.shape[0]):
        for col in range(matrix.shape[1]):
            out[row, col] = matrix[row, col] * scale[row if rows else col]
    return out


@njit(cache=True)
def copy_into(target: np.ndarray, source: np.ndarray) -> None:
    """target[:, :] = source (m, n) in loops (numba's broadcasting slice assignment takes seconds to compile)."""
    for row in range(source.shape[0]):
        for col in range(source.shape[1]):
            target[row, col] = source[row, col]


@njit(cache=True)
def subtract_in_place(matrix: np.ndarray, other: np.ndarray) -> None:
    """matrix -= other, both (m, n)."""
    for row in range(matrix.shape[0]):
        for col in range(matrix.shape[1]):
            matrix[row, col] -= other[row, col]


@njit(cache=True)
def weighted_columns(matrix: np.ndarray, inverse_sqrt: np.ndarray, transform: np.ndarray) -> np.ndarray:
    """X L^-T (m, n) of X (m, n), W = L L^T: X W^-1/2 for a diagonal W (``inverse_sqrt`` (n,)), X L^-T for a
    full one (``transform`` (n, n)), X itself when both are empty (W = I; not a copy)."""
    if inverse_sqrt.size:
        return scale_matrix(matrix, inverse_sqrt, False)
    if transform.size:
        return product(matrix, transform)
    return matrix


@njit(cache=True)
def weighted_norm(matrix: np.ndarray, inverse_sqrt: np.ndarray, transform: np.ndarray) -> float:
    """The Frobenius norm of X L^-T (W = L L^T; W as :func:`weighted_inverse_into` takes it) of X (m, n)."""
    weighted = weighted_columns(matrix, inverse_sqrt, transform)
    total = 0.0
    for row in range(weighted.shape[0]):
        for col in range(weighted.shape[1]):
            total += weighted[row, col] * weighted[row, col]
    return np.sqrt(total)


@njit(cache=True)
def weighted_inverse_into(matrix: np.ndarray, inverse_sqrt: np.ndarray, transform: np.ndarray, damping: float,
                          epsilon: float, lambda_max: float, rcond: float, floor: float,
                          out: np.ndarray) -> tuple[bool, float, float]:
    """The weighted, damped inverse L^-T (X L^-T)^+ (n, m) of X (m, n), W = L L^T, written to ``out``.

    Args:
        matrix: X (m, n).
        inverse_sqrt: W^-1/2 (n,) of a diagonal W, or empty; transform: L^-T (n, n) of a full W, or empty
            (both empty: W = I).
        damping, epsilon, lambda_max, rcond, floor: as :func:`svd_inverse_into` (floor: of X L^-T).
        out: (n, m).

    Returns:
        (converged, sigma_min of X L^-T, l used), as :func:`svd_inverse_into`.
    """
    weighted = weighted_columns(matrix, inverse_sqrt, transform)  # X L^-T
    if transform.size and not inverse_sqrt.size:
        scaled = np.empty_like(out)  # (X L^-T)^+, then L^-T times it
        converged, sigma_min, used = svd_inverse_into(weighted, damping, epsilon, lambda_max, rcond, floor, scaled)
        copy_into(out, product(transform, scaled))
        return converged, sigma_min, used
    converged, sigma_min, used = svd_inverse_into(weighted, damping, epsilon, lambda_max, rcond, floor, out)
    if inverse_sqrt.size:  # W^-1/2 (X W^-1/2)^+: its rows scale
        for row in range(out.shape[0]):
            for col in range(out.shape[1]):
                out[row, col] *= inverse_sqrt[row]
    return converged, sigma_min, used


@njit(cache=True)
def level_inverse_into(scaled: np.ndarray, power: np.ndarray, projector: np.ndarray, root_eta: float,
                       inverse_sqrt: np.ndarray, transform: np.ndarray, damping: float, epsilon: float,
                       lambda_max: float, rcond: float, floor: float, out: np.ndarray) -> tuple[bool, float, float]:
    """The iCAT inverse X^{#,A,Q} (n, m) of one level (Simetti and Casalino 2016), written to ``out``.

    The weighted, damped inverse of Z = [A^1/2 X; eta^1/2 (I - Q)] (without the eta rows when ``root_eta``
    is 0), its first m columns scaled by a^1.5: (X^T A X + eta (I - Q)^T (I - Q))^# X^T A A.

    Args:
        scaled: A^1/2 X (m, n); power: a^1.5 (m,); projector: Q (n, n) (read only with eta rows).
        root_eta: eta^1/2 >= 0 (0: no eta rows, the inverse X^{#,A,I}).
        inverse_sqrt, transform, damping, epsilon, lambda_max, rcond, floor: as :func:`weighted_inverse_into`.
        out: (n, m).

    Returns:
        (converged, sigma_min of the weighted Z, l used), as :func:`svd_inverse_into`.
    """
    active, size = scaled.shape
    stacked = scaled
    if root_eta > 0.0:
        stacked = np.empty((active + size, size))
        copy_into(stacked[:active], scaled)
        for row in range(size):
            for col in range(size):
                stacked[active + row, col] = root_eta * ((1.0 if row == col else 0.0) - projector[row, col])
    full = np.empty((size, stacked.shape[0]))
    converged, sigma_min, used = weighted_inverse_into(stacked, inverse_sqrt, transform, damping, epsilon,
                                                       lambda_max, rcond, floor, full)
    for row in range(size):
        for col in range(active):
            out[row, col] = full[row, col] * power[col]
    return converged, sigma_min, used


@njit(cache=True)
def icat_into(jacobians: np.ndarray, references: np.ndarray, activations: np.ndarray, offsets: np.ndarray,
              equality: np.ndarray, inverse_sqrt: np.ndarray, transform: np.ndarray, damping: float, epsilon: float,
              lambda_max: float, rcond: float, eta: float, contributions: np.ndarray,
              sigmas: np.ndarray) -> tuple[bool, float]:
    """The iCAT recursion over priority levels (Simetti and Casalino 2016; ``uvms.solvers.set_based``).

    With rho_0 = 0 and Q_0 = I, level k (rows offsets[k]:offsets[k+1] of the stacks) gives
    rho_k - rho_{k-1} = Q (J Q)^{#,A,I} W_k (xdot_k - J_k rho_{k-1}) and Q_k = Q (I - (J Q)^{#,A,I} J Q), the
    inverses X^{#,A,Q} of the weighted, damped inverse of Z = [A^1/2 X; eta^1/2 (I - Q)]; rows with a = 0
    are left out (they add nothing), and while no level above has moved anything (Q = I) a level of
    activations 1 is solved as CLIK is. Below the first level, singular values of X = J Q under rcond times
    the norm of the unprojected A^1/2 J (weighted) count as zero: the rounding Q keeps of the levels above.

    Args:
        jacobians: the levels' solved rows stacked (M, n); references: (M,); activations: (M,) in [0, 1].
        offsets: (L + 1,) the first row of each level, then M.
        equality: (L,) the level holds equality tasks only.
        inverse_sqrt, transform: W as :func:`weighted_inverse_into` takes it.
        damping, epsilon, lambda_max: the damping of (J Q)^{#,A,I} (W_k's inverse is undamped).
        rcond: the pseudo-inverse's cut-off; eta: the weight of the (I - Q) term >= 0.
        contributions: (L, n) written with rho_k - rho_{k-1}; sigmas: (L,) written with each level's sigma_min.

    Returns:
        (converged (False: a non-finite level), the largest damping used).
    """
    size = jacobians.shape[1]
    rho = np.zeros(size)
    projector = np.zeros((size, size))  # Q = I
    for entry in range(size):
        projector[entry, entry] = 1.0
    unrestricted = True  # Q = I exactly: no level above has moved anything
    undamped = epsilon == 0.0 and damping == 0.0
    root_eta = np.sqrt(eta)
    largest = 0.0
    for level in range(offsets.size - 1):
        first, last = offsets[level], offsets[level + 1]
        contributions[level, :] = 0.0
        sigmas[level] = 0.0
        active = 0
        ones = True
        for row in range(first, last):
            if activations[row] > 0.0:
                active += 1
            if activations[row] != 1.0:
                ones = False
        if not equality[level] and active == 0:
            continue
        jacobian = jacobians[first:last]
        remaining = apply(jacobian, rho)
        for row in range(last - first):
            remaining[row] = references[first + row] - remaining[row]  # xdot_k - J_k rho_{k-1}
        if unrestricted and (equality[level] or ones):  # the CLIK case
            inverse = np.empty((size, last - first))
            converged, sigma_min, used = weighted_inverse_into(jacobian, inverse_sqrt, transform, damping, epsilon,
                                                               lambda_max, rcond, 0.0, inverse)
            if not converged:
                return False, largest
            contribution = apply(inverse, remaining)
            subtract_in_place(projector, product(inverse, jacobian))
        else:
            rows = np.empty(active, dtype=np.int64)  # the active rows, their a^1/2 and a^1.5
            root, power = np.empty(active), np.empty(active)
            count = 0
            for row in range(last - first):
                value = activations[first + row]
                if value > 0.0:
                    rows[count], root[count], power[count] = row, np.sqrt(value), value ** 1.5
                    count += 1
            selected = np.empty((active, size))
            for row in range(active):
                for col in range(size):
                    selected[row, col] = jacobian[rows[row], col]
            projected = selected if unrestricted else product(selected, projector)  # X (m, n)
            scaled = scale_matrix(projected, root, True)  # A^1/2 X
            # X = J Q keeps the rounding of the levels above (Q of a level that takes every direction is
            # rounding noise): its singular values count from the scale of the unprojected A^1/2 J, not its own
            floor = 0.0 if unrestricted else rcond * weighted_norm(scale_matrix(selected, root, True), inverse_sqrt,
                                                                   transform)
            inverse = np.empty((size, active))  # X^{#,A,I}, damped
            converged, sigma_min, used = level_inverse_into(scaled, power, projector, 0.0, inverse_sqrt, transform,
                                                            damping, epsilon, lambda_max, rcond, floor, inverse)
            if not converged:
                return False, largest
            if unrestricted and undamped:
                regularized = inverse
            else:  # X^{#,A,Q}, undamped (Q = I: no eta rows)
                regularized = np.empty((size, active))
                converged, _, _ = level_inverse_into(scaled, power, projector, 0.0 if unrestricted else root_eta,
                                                     inverse_sqrt, transform, 0.0, 0.0, 0.0, rcond, floor,
                                                     regularized)
                if not converged:
                    return False, largest
            transfer = product(projected, regularized)  # W_k (m, m)
            wanted = np.empty(active)
            for row in range(active):
                wanted[row] = remaining[rows[row]]
            contribution = apply(projector, apply(inverse, apply(transfer, wanted)))
            subtract_in_place(projector, product(projector, product(inverse, projected)))
        for entry in range(size):
            rho[entry] += contribution[entry]
        unrestricted = False
        for entry in range(size):
            contributions[level, entry] = contribution[entry]
        sigmas[level] = sigma_min
        largest = max(largest, used)
    return True, largest


@njit(cache=True)
def clik_solution_into(jacobian: np.ndarray, command: np.ndarray, inverse_sqrt: np.ndarray, transform: np.ndarray,
                       damping: float, epsilon: float, lambda_max: float, rcond: float, z0: np.ndarray,
                       out: np.ndarray) -> tuple[bool, float, float]:
    """The CLIK solution x = J_W^+ (c - J z0) + z0 (n,), J_W^+ the weighted, damped inverse, in one call.

    It is J_W^+ c + (I - J_W^+ J) z0 of hoang2011 eq. 27 (amundsen2018 eq. 7 with damping), with
    J_W^+ = L^-T (J L^-T)^+ for W = L L^T, the inverse of :func:`svd_inverse_into` applied to one vector.

    Args:
        jacobian: J (k, n) of the solved columns.
        command: c = xdot_d + K e (k,).
        inverse_sqrt: W^-1/2 (n,) of a diagonal W, or empty.
        transform: L^-T (n, n) of a full W, or empty (used when ``inverse_sqrt`` is empty; both empty: W = I).
        damping, epsilon, lambda_max, rcond: as :func:`svd_inverse_into`.
        z0: the null-space motion (n,), or empty for none.
        out: (n,) written with x.

    Returns:
        (converged (False for a non-finite J), sigma_min of J L^-T (0 when k > n), l used).
    """
    rows, columns = jacobian.shape
    rhs = command.copy()  # c - J z0
    if z0.size:
        for row in range(rows):
            for col in range(columns):
                rhs[row] -= jacobian[row, col] * z0[col]
    scaled = weighted_columns(jacobian, inverse_sqrt, transform)  # J L^-T
    converged, wide, work, rotation, factors, sigma_min, used = decompose(scaled, damping, epsilon, lambda_max,
                                                                          rcond, 0.0)
    if not converged:
        return False, sigma_min, used
    left, right = (rotation, work) if wide else (work, rotation)  # A^+ = right^T diag(factors) left
    solution = np.zeros(columns)  # (J L^-T)^+ rhs
    for row in range(left.shape[0]):
        if factors[row] == 0.0:
            continue
        projected = 0.0
        for col in range(left.shape[1]):
            projected += left[row, col] * rhs[col]
        projected *= factors[row]
        for col in range(right.shape[1]):
            solution[col] += right[row, col] * projected
    if inverse_sqrt.size:
        for col in range(columns):
            solution[col] *= inverse_sqrt[col]
    elif transform.size:
        solution = apply(transform, solution)
    for col in range(columns):
        out[col] = solution[col] + z0[col] if z0.size else solution[col]
    return True, sigma_min, used


@njit(cache=True)
def cholesky_solve_in_place(system: np.ndarray, rhs: np.ndarray) -> bool:
    """Solve A y = b for a symmetric positive definite A (k, k) by A = L L^T, overwriting both.

    The lower triangle of ``system`` becomes L and ``rhs`` becomes y; the upper triangle is not read.

    Returns:
        False when A is not numerically positive definite (a pivot <= 0; ``rhs`` is then partly
        overwritten and not a solution), True otherwise.
    """
    size = system.shape[0]
    for col in range(size):
        pivot = system[col, col]
        for inner in range(col):
            pivot -= system[col, inner] * system[col, inner]
        if not pivot > 0.0:  # also catches NaN
            return False
        pivot = np.sqrt(pivot)
        system[col, col] = pivot
        for row in range(col + 1, size):
            value = system[row, col]
            for inner in range(col):
                value -= system[row, inner] * system[col, inner]
            system[row, col] = value / pivot
    for row in range(size):  # L z = b
        value = rhs[row]
        for inner in range(row):
            value -= system[row, inner] * rhs[inner]
        rhs[row] = value / system[row, row]
    for row in range(size - 1, -1, -1):  # L^T y = z
        value = rhs[row]
        for inner in range(row + 1, size):
            value -= system[inner, row] * rhs[inner]
        rhs[row] = value / system[row, row]
    return True


@njit(cache=True)
def dls_solve_into(jacobian: np.ndarray, rhs: np.ndarray, damping_squared: float, out: np.ndarray) -> bool:
    """out = J^T (J J^T + d I)^-1 b (n,): the DLS solution for one right-hand side, in normal-equation form.

    Args:
        jacobian: J (k, n); rhs: b (k,) (not modified); damping_squared: d = l^2 >= 0.
        out: (n,) written with the solution.

    Returns:
        False when J J^T + d I is not numerically positive definite (``out`` is then not written).
    """
    rows, columns = jacobian.shape
    system = np.empty((rows, rows))  # J J^T + d I (lower triangle)
    solution = np.empty(rows)
    for row in range(rows):
        solution[row] = rhs[row]
        for other in range(row + 1):
            dot = 0.0
            for col in range(columns):
                dot += jacobian[row, col] * jacobian[other, col]
            system[row, other] = dot
        system[row, row] += damping_squared
    if not cholesky_solve_in_place(system, solution):
        return False
    for col in range(columns):  # J^T y
        value = 0.0
        for row in range(rows):
            value += jacobian[row, col] * solution[row]
        out[col] = value
    return True


@njit(cache=True)
def rotation_to_target(transform_frame_to_world: np.ndarray, target_rotation: np.ndarray, out: np.ndarray) -> None:
    """out = R_d R^T (3, 3), the rotation whose log3 is the orientation error in world axes.

    Args:
        transform_frame_to_world: the frame's homogeneous pose (4, 4) (its rotation R is read).
        target_rotation: R_d (3, 3).
        out: (3, 3) written.
    """
    for row in range(3):
        for col in range(3):
            out[row, col] = (target_rotation[row, 0] * transform_frame_to_world[col, 0]
                             + target_rotation[row, 1] * transform_frame_to_world[col, 1]
                             + target_rotation[row, 2] * transform_frame_to_world[col, 2])


@njit(cache=True)
def pose_error_norm(transform_frame_to_world: np.ndarray, target_translation: np.ndarray,
                    rotation_error: np.ndarray, error: np.ndarray) -> float:
    """|e| [m, rad] of the pose error e = [p_d - p; log3(R_d R^T)], written to ``error`` (6,).

    Args:
        transform_frame_to_world: the frame's homogeneous pose (4, 4) (its translation is read).
        target_translation: p_d (3,) [m].
        rotation_error: log3(R_d R^T) (3,) [rad], from Pinocchio.
        error: (6,) written with e.
    """
    squared = 0.0
    for axis in range(3):
        error[axis] = target_translation[axis] - transform_frame_to_world[axis, 3]
        error[3 + axis] = rotation_error[axis]
        squared += error[axis] * error[axis] + rotation_error[axis] * rotation_error[axis]
    return np.sqrt(squared)


@njit(cache=True)
def project_into_box(q: np.ndarray, index: np.ndarray, lower: np.ndarray, upper: np.ndarray,
                     turns: np.ndarray) -> None:
    """Bring the bounded coordinates q[index] into [lower, upper] in place.

    A revolute coordinate (``turns``) outside its limits first moves by the multiple of 2 pi that puts it
    at or above ``lower``, when that lands inside (the same pose); what is still outside is clipped.
    """
    for entry in range(index.size):
        value = q[index[entry]]
        low, high = lower[entry], upper[entry]
        if value < low or value > high:
            if turns[entry]:
                wrapped = low + np.mod(value - low, 2.0 * np.pi)
                if wrapped <= high:
                    value = wrapped
            q[index[entry]] = min(max(value, low), high)


@njit(cache=True)
def joint_limit_motion_into(q: np.ndarray, q_index: np.ndarray, v_index: np.ndarray, weights: np.ndarray,
                            middle: np.ndarray, range_squared: np.ndarray, alpha: float, z0: np.ndarray) -> None:
    """z0 = -alpha dS/dv of the joint-limit potential (hoang2011 eq. 20-21), written to ``z0`` (n,).

    z0[v_index] = -alpha c (q[q_index] - qbar) / range^2 (the operations of
    ``JointLimitPotential.arm_gradient``), zero elsewhere; the arrays are a ``NullspaceTerms``'.
    """
    z0[:] = 0.0
    for entry in range(q_index.size):
        z0[v_index[entry]] = -alpha * (weights[entry] * (q[q_index[entry]] - middle[entry]) / range_squared[entry])


@njit(cache=True)
def bell_value(depth: float, band: float, step: bool) -> float:
    """Activation in [0, 1] of a row ``depth`` inside its border over ``band`` > 0 (iCAT).

    depth <= 0 (on or outside the border): 1; depth >= band: 0; between: (1 + cos(pi depth / band)) / 2
    (the cosine bell, C1), or 1 (``step``: a hard switch).
    """
    ratio = depth / band
    if step:
        return 1.0 if ratio < 1.0 else 0.0
    return 0.5 * (1.0 + np.cos(np.pi * min(max(ratio, 0.0), 1.0)))


@njit(cache=True)
def bell_into(depth: np.ndarray, band: np.ndarray, step: bool, out: np.ndarray) -> None:
    """:func:`bell_value` of each row (k,), written to ``out`` (k,)."""
    for row in range(depth.size):
        out[row] = bell_value(depth[row], band[row], step)


@njit(cache=True)
def activation_reference_into(value: np.ndarray, lower: np.ndarray, upper: np.ndarray, band: np.ndarray,
                              inner_lower: np.ndarray, inner_upper: np.ndarray, gain: float, step: bool,
                              activation: np.ndarray, reference: np.ndarray) -> None:
    """The activation and the reference rate (k,) of an inequality objective at x = ``value`` (k,).

    Each row answers to its nearer bound (the only one when the other is infinite): activation the bell of
    its depth inside that bound, reference gain (x* - x) with x* = lower + band or upper - band.
    """
    for row in range(value.size):
        near_lower = (value[row] - lower[row]) <= (upper[row] - value[row])
        depth = value[row] - lower[row] if near_lower else upper[row] - value[row]
        activation[row] = bell_value(depth, band[row], step)
        reference[row] = gain * ((inner_lower[row] if near_lower else inner_upper[row]) - value[row])


@njit(cache=True)
def rate_bounds_into(q: np.ndarray, q_index: np.ndarray, v_index: np.ndarray, low: np.ndarray, high: np.ndarray,
                     dt: float, fraction: float, lower: np.ndarray, upper: np.ndarray) -> None:
    """Velocity bounds (nv,) that keep joints inside [low, high] after one step of ``dt`` [s].

    lower[v] = max over the rows of v of fraction (low - q) / dt, upper[v] = min of fraction (high - q) / dt;
    -inf / +inf on the entries no row bounds.

    Args:
        q: configuration (nq,); q_index, v_index: (m,) each row's coordinate in q and entry of v.
        low, high: (m,) the position limits kept; dt: the step [s] > 0; fraction: in (0, 1].
        lower, upper: (nv,) written.
    """
    lower[:] = -np.inf
    upper[:] = np.inf
    for row in range(q_index.size):
        now, entry = q[q_index[row]], v_index[row]
        lower[entry] = max(lower[entry], fraction * (low[row] - now) / dt)
        upper[entry] = min(upper[entry], fraction * (high[row] - now) / dt)


@njit(cache=True)
def velocity_box_into(maximum: np.ndarray, rate_lower: np.ndarray, rate_upper: np.ndarray, contain_zero: bool,
                      lower: np.ndarray, upper: np.ndarray) -> None:
    """The box (nv,) of rate bounds clipped into |v_i| <= maximum_i, never empty (``uvms.solvers.saturation``).

    Where two bounds disagree the tighter upper one wins; ``contain_zero`` widens the box to hold v = 0.
    """
    for entry in range(maximum.size):
        bound = maximum[entry]
        low = min(max(rate_lower[entry], -bound), bound)
        high = min(max(rate_upper[entry], -bound), bound)
        low = min(low, high)
        if contain_zero:
            low, high = min(low, 0.0), max(high, 0.0)
        lower[entry], upper[entry] = low, high


@njit(cache=True)
def inside_box(values: np.ndarray, lower: np.ndarray, upper: np.ndarray, tolerance: float) -> bool:
    """Whether lower - tolerance <= values <= upper + tolerance, entry by entry."""
    for entry in range(values.size):
        if not (values[entry] >= lower[entry] - tolerance and values[entry] <= upper[entry] + tolerance):
            return False
    return True


@njit(cache=True)
def scale_lowest_first_into(contributions: np.ndarray, lower: np.ndarray, upper: np.ndarray, tolerance: float,
                            out: np.ndarray, scales: np.ndarray) -> None:
    """sum_k s_k c_k inside the box lower <= v <= upper (which holds 0), the lowest levels scaled first.

    If the sum of the contributions c_k (L, nv) leaves the box, the lowest level is scaled by the largest
    s in [0, 1] that keeps base + s c_k inside, base the sum of the levels above; if even s = 0 does not,
    it is dropped and the next one up is scaled (``uvms.solvers.saturation``).

    Args:
        contributions: c_k (L, nv), highest priority first.
        lower, upper: the box (nv,); tolerance: the slack within which a value counts as inside.
        out: (nv,) written with the scaled sum; scales: (L,) written with the s_k.
    """
    count, size = contributions.shape
    partial = np.zeros((count + 1, size))  # partial[k]: the sum of the k highest levels
    for level in range(count):
        for entry in range(size):
            partial[level + 1, entry] = partial[level, entry] + contributions[level, entry]
    scales[:] = 1.0
    if inside_box(partial[count], lower, upper, tolerance):
        for entry in range(size):
            out[entry] = partial[count, entry]
        return
    for level in range(count - 1, -1, -1):
        scales[level] = 0.0
        base = partial[level]  # the levels above, in full
        if inside_box(base, lower, upper, tolerance):
            scale = np.inf  # the largest s with lower <= base + s c <= upper (only moving entries bound it)
            for entry in range(size):
                step = contributions[level, entry]
                if step > 0.0:
                    scale = min(scale, (upper[entry] - base[entry]) / step)
                elif step < 0.0:
                    scale = min(scale, (lower[entry] - base[entry]) / step)
            scale = min(max(scale, 0.0), 1.0)
            scales[level] = scale
            for entry in range(size):
                out[entry] = base[entry] + scale * contributions[level, entry]
            return
    out[:] = 0.0


@njit(cache=True)
def dls_pose_velocity(
    jacobian: np.ndarray,
    transform_frame_to_world: np.ndarray,
    target_translation: np.ndarray,
    rotation_error: np.ndarray,
    gain: float,
    feedforward: np.ndarray,
    damping_squared: float,
    q: np.ndarray,
    q_index: np.ndarray,
    v_index: np.ndarray,
    weights: np.ndarray,
    middle: np.ndarray,
    range_squared: np.ndarray,
    alpha: float,
    scale: float,
    error: np.ndarray,
    out: np.ndarray,
) -> bool:
    """scale * v (nv,) of the DLS CLIK of one 6-D pose task with a joint-limit null-space motion.

        e = [p_d - p; log3(R_d R^T)],  c = K e + xdot_d,  z0 = -alpha dS/dv (:func:`joint_limit_motion_into`)
        v = z0 + J^T (J J^T + d I)^-1 (c - J z0)

    which is J^+ c + (I - J^+ J) z0 with the DLS inverse J^+ = J^T (J J^T + d I)^-1.

    Args:
        jacobian: J (6, nv), world-aligned.
        transform_frame_to_world: the frame's homogeneous pose (4, 4) (its translation is read).
        target_translation: p_d (3,) [m].
        rotation_error: log3(R_d R^T) (3,) [rad], from Pinocchio.
        gain: K [1/s].
        feedforward: xdot_d (6,) [m/s, rad/s].
        damping_squared: d = l^2 > 0.
        q: the configuration (nq,).
        q_index, v_index, weights, middle, range_squared, alpha: the potential's ``NullspaceTerms``.
        scale: the factor on v written to ``out`` (a step's dt [s], or 1).
        error: (6,) written with e [m, rad].
        out: (nv,) written with scale * v.

    Returns:
        False when J J^T + d I is not numerically positive definite (``out`` is then not written).
    """
    rows, columns = jacobian.shape
    pose_error_norm(transform_frame_to_world, target_translation, rotation_error, error)
    z0 = np.empty(columns)
    joint_limit_motion_into(q, q_index, v_index, weights, middle, range_squared, alpha, z0)
    rhs = np.empty(rows)  # c - J z0
    for row in range(rows):
        value = gain * error[row] + feedforward[row]
        for col in range(columns):
            value -= jacobian[row, col] * z0[col]
        rhs[row] = value
    if not dls_solve_into(jacobian, rhs, damping_squared, out):
        return False
    for col in range(columns):  # z0 + J^+ (c - J z0)
        out[col] = scale * (z0[col] + out[col])
    return True
