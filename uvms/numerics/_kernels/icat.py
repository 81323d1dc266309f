"""The iCAT recursion of the set-based solver (Simetti and Casalino 2016; ``uvms.solvers.set_based``).

Each level's activation-weighted, regularized inverse X^{#,A,Q} and the recursion over priority levels
with its projector Q, in one compiled call.

The module imports numba, so it is loaded where a solver first uses it, not by ``import uvms``; its kernels
compile at their first call and are cached on disk (``cache=True``, see :mod:`uvms.numerics._kernels`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .boxes import saturated_sum_into
from .dense import apply, copy_into, product, scale_matrix, subtract_in_place
from .qr import gram_rows
from .svd import EPSILON
from .weighted import weighted_inverse_into, weighted_norm

__all__ = ["eta_rows", "icat_into", "icat_saturated_into", "level_inverse_into"]


@njit(cache=True, inline="always")
def eta_rows(scaled_unprojected: np.ndarray, projector: np.ndarray, root_eta: float) -> np.ndarray:
    """The eta rows eta^1/2 D (I - Q) (n, n) of a level: the directions the levels above hold (Q their projector
    (n, n)), each coordinate weighed by D = diag(|column j of A^1/2 J|), how much it moves the level's rows
    (A^1/2 J = ``scaled_unprojected`` (m, n))."""
    size = projector.shape[0]
    rows = np.empty((size, size))
    for row in range(size):
        norm = 0.0
        for k in range(scaled_unprojected.shape[0]):
            norm += scaled_unprojected[k, row] ** 2
        weight = root_eta * np.sqrt(norm)
        for col in range(size):
            rows[row, col] = weight * ((1.0 if row == col else 0.0) - projector[row, col])
    return rows


@njit(cache=True, inline="always")
def level_inverse_into(scaled: np.ndarray, power: np.ndarray, penalty: np.ndarray, inverse_sqrt: np.ndarray,
                       transform: np.ndarray, damping: float, epsilon: float, lambda_max: float, rcond: float,
                       floor: float, out: np.ndarray) -> tuple[bool, float, float]:
    """The iCAT inverse X^{#,A,Q} (n, m) of one level (Simetti and Casalino 2016), written to ``out``.

    The weighted, damped inverse of Z = [A^1/2 X; P] (without P when it has no row), its first m columns
    scaled by a^1.5: (X^T A X + P^T P)^# X^T A A, P the eta rows (:func:`eta_rows`). Undamped, P is replaced
    by its few rows F with the same Gram matrix (:func:`~.qr.gram_rows`): the same inverse to rounding.

    Args:
        scaled: A^1/2 X (m, n); power: a^1.5 (m,); penalty: the eta rows P (p, n), p = 0 for X^{#,A,I}.
        inverse_sqrt, transform, damping, epsilon, lambda_max, rcond, floor: as
            :func:`~.weighted.weighted_inverse_into`.
        out: (n, m).

    Returns:
        (converged, sigma_min of the weighted Z, l used), as :func:`~.svd.svd_inverse_into`.
    """
    active, size = scaled.shape
    stacked = scaled
    compressed = penalty.shape[0] > 0 and damping == 0.0 and epsilon == 0.0
    if compressed:
        # P's rank is the number of directions the levels above hold: its few rows F with F^T F = P^T P
        # (rows at the stack's rounding level left out) give the same Gram matrix, and the inverse's first m
        # columns (X^T A X + P^T P)^# X^T A^1/2, from m + r rows instead of m + n
        total = 0.0
        for row in range(active):
            for col in range(size):
                total += scaled[row, col] * scaled[row, col]
        for row in range(penalty.shape[0]):
            for col in range(size):
                total += penalty[row, col] * penalty[row, col]
        factor = gram_rows(penalty, (size * EPSILON) ** 2 * total)
        stacked = np.empty((active + factor.shape[0], size))
        copy_into(stacked[:active], scaled)
        copy_into(stacked[active:], factor)
    elif penalty.shape[0] > 0:  # damped: l, and sigma_min the variable damping reads, are those of Z (m + n, n)
        stacked = np.empty((active + penalty.shape[0], size))
        copy_into(stacked[:active], scaled)
        copy_into(stacked[active:], penalty)
    full = np.empty((size, stacked.shape[0]))
    converged, sigma_min, used = weighted_inverse_into(stacked, inverse_sqrt, transform, damping, epsilon,
                                                       lambda_max, rcond, floor, full)
    for row in range(size):
        for col in range(active):
            out[row, col] = full[row, col] * power[col]
    if compressed:
        sigma_min = 0.0  # of Z (m + n rows, tall), as without the compression
    return converged, sigma_min, used


@njit(cache=True, inline="always")
def icat_into(jacobians: np.ndarray, references: np.ndarray, activations: np.ndarray, offsets: np.ndarray,
              equality: np.ndarray, inverse_sqrt: np.ndarray, transform: np.ndarray, damping: float, epsilon: float,
              lambda_max: float, rcond: float, eta: float, contributions: np.ndarray,
              sigmas: np.ndarray) -> tuple[bool, float]:
    """The iCAT recursion over priority levels (Simetti and Casalino 2016; ``uvms.solvers.set_based``).

    With rho_0 = 0 and Q_0 = I, level k (rows offsets[k]:offsets[k+1] of the stacks) gives
    rho_k - rho_{k-1} = Q (J Q)^{#,A,I} W_k (xdot_k - J_k rho_{k-1}) and Q_k = Q (I - (J Q)^{#,A,I} J Q), the
    inverses X^{#,A,Q} of the weighted, damped inverse of Z = [A^1/2 X; eta^1/2 D (I - Q)]; rows with a = 0
    are left out (they add nothing), and while no level above has moved anything (Q = I) a level of
    activations 1 is solved as CLIK is. Below the first level, singular values of X = J Q under rcond times
    the norm of the unprojected A^1/2 J (weighted) count as zero: the rounding Q keeps of the levels above.

    Args:
        jacobians: the levels' solved rows stacked (M, n); references: (M,); activations: (M,) in [0, 1].
        offsets: (L + 1,) the first row of each level, then M.
        equality: (L,) the level holds equality tasks only.
        inverse_sqrt, transform: W as :func:`~.weighted.weighted_inverse_into` takes it.
        damping, epsilon, lambda_max: the damping of (J Q)^{#,A,I} (W_k's inverse is undamped).
        rcond: the pseudo-inverse's cut-off; eta: the weight of the eta rows (:func:`eta_rows`) >= 0.
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
    no_rows = np.zeros((0, size))
    largest = 0.0
    last_level = offsets.size - 2
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
            if level < last_level:  # Q of the levels above: no level below reads the last one
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
            unprojected = scale_matrix(selected, root, True)  # A^1/2 J
            floor = 0.0 if unrestricted else rcond * weighted_norm(unprojected, inverse_sqrt, transform)
            inverse = np.empty((size, active))  # X^{#,A,I}, damped
            converged, sigma_min, used = level_inverse_into(scaled, power, no_rows, inverse_sqrt, transform,
                                                            damping, epsilon, lambda_max, rcond, floor, inverse)
            if not converged:
                return False, largest
            if unrestricted and undamped:
                regularized = inverse
            else:  # X^{#,A,Q}, undamped (Q = I: no eta rows)
                regularized = np.empty((size, active))
                penalty = no_rows if unrestricted or root_eta == 0.0 else \
                    eta_rows(unprojected, projector, root_eta)
                converged, _, _ = level_inverse_into(scaled, power, penalty, inverse_sqrt, transform, 0.0, 0.0, 0.0,
                                                     rcond, floor, regularized)
                if not converged:
                    return False, largest
            transfer = product(projected, regularized)  # W_k (m, m)
            wanted = np.empty(active)
            for row in range(active):
                wanted[row] = remaining[rows[row]]
            contribution = apply(projector, apply(inverse, apply(transfer, wanted)))
            if level < last_level:
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
def icat_saturated_into(jacobians: np.ndarray, references: np.ndarray, activations: np.ndarray, offsets: np.ndarray,
                        equality: np.ndarray, inverse_sqrt: np.ndarray, transform: np.ndarray, damping: float,
                        epsilon: float, lambda_max: float, rcond: float, eta: float, q: np.ndarray,
                        q_index: np.ndarray, v_index: np.ndarray, low: np.ndarray, high: np.ndarray, dt: float,
                        fraction: float, maximum: np.ndarray, tolerance: float, contributions: np.ndarray,
                        sigmas: np.ndarray, total: np.ndarray, scales: np.ndarray) -> tuple[bool, float, float]:
    """:func:`icat_into`, then the levels' sum inside the velocity box
    (:func:`~.boxes.saturated_sum_into` with the contributions in v: every column solved, none free floating), in
    one call: the set-based solver's step after its rows are stacked.

    Args:
        jacobians ... sigmas: as :func:`icat_into`; q, q_index ... tolerance: as :func:`~.boxes.saturated_sum_into`
            (``check_inside`` True); total: (n,) written with the sum; scales: (L,) written.

    Returns:
        (converged (False: a non-finite level; total and scales not written), the largest damping used, the speed
        ratio of the sum).
    """
    converged, largest = icat_into(jacobians, references, activations, offsets, equality, inverse_sqrt, transform,
                                   damping, epsilon, lambda_max, rcond, eta, contributions, sigmas)
    if not converged:
        return False, largest, 0.0
    ratio = saturated_sum_into(contributions, contributions, q, q_index, v_index, low, high, dt, fraction, maximum,
                               True, tolerance, total, scales)
    return True, largest, ratio
