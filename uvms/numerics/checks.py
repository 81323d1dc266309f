"""Input validators of the solver layer: one place, one error type (:class:`uvms.errors.SolverInputError`).

Each returns the value as the solver uses it (a float, an int, a float array)
and raises with a message that names the argument and what would be valid.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from ..errors import SolverInputError
from .validate import finite_array


def check_scalar(value: float, what: str, *, positive: bool = False) -> float:
    """A finite number >= 0 (``positive``: > 0).

    Args:
        value: the number given.
        what: its name in the message, e.g. "damping", "alpha", "dt".
        positive: refuse 0 as well.

    Raises:
        SolverInputError: not a number, not finite, negative (or zero when ``positive``).
    """
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise SolverInputError(f"{what} must be a number, got {value!r}") from None
    if not np.isfinite(number) or number < 0.0 or (positive and number == 0.0):
        raise SolverInputError(f"{what} must be finite and {'>' if positive else '>='} 0, got {value!r}")
    return number


def numbers(value: object, what_is_valid: str) -> np.ndarray:
    """``value`` as a float array, or SolverInputError saying what is valid (text, None, ragged lists)."""
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise SolverInputError(f"{what_is_valid}, got {value!r}") from None


def check_damping(damping: float) -> float:
    """A finite damping factor lambda >= 0 [-]."""
    return check_scalar(damping, "damping")


def check_count(value: int, what: str, minimum: int = 0) -> int:
    """An integer >= ``minimum`` (iterations, restarts)."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise SolverInputError(f"{what} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def check_matrix(matrix: np.ndarray, what: str, shape: tuple[int | None, int | None] = (None, None)) -> np.ndarray:
    """A finite 2-D float array of the given shape (None: any size on that axis)."""
    return finite_array(matrix, what, shape, error=SolverInputError)


def check_vector(vector: np.ndarray, what: str, size: int) -> np.ndarray:
    """A finite float array of shape (size,); the message names the size expected."""
    try:
        array = finite_array(vector, what, (size,), error=SolverInputError)
    except SolverInputError:
        raise SolverInputError(f"{what} must be {size} finite numbers, got {vector!r}") from None
    return array


def check_weights(weights: np.ndarray, size: int, what: str = "W", note: str = "") -> np.ndarray:
    """A weighting matrix W: (size,) positive diagonal, or (size, size) finite and symmetric.

    Positive definiteness of a full W is the Cholesky factorization's to find
    (:func:`~uvms.numerics.inverses.weights_factor`).

    Args:
        weights: W, (size,) or (size, size).
        size: the number of solved columns (nv, or n_arm for the generalized Jacobian).
        what: the name of W in the message (e.g. "weights", "solver.weights").
        note: what the columns are, added to a wrong-shape message (e.g. "free floating: the arm joints only").

    Raises:
        SolverInputError: wrong shape, non-finite, a diagonal entry <= 0, or a full W not symmetric.
    """
    hint = f" ({note})" if note else ""
    weights = numbers(weights, f"{what} must be ({size},) or ({size}, {size}) positive numbers{hint}")
    if weights.ndim == 1:
        if weights.shape != (size,) or not np.all(np.isfinite(weights)):
            raise SolverInputError(f"{what} must be ({size},) or ({size}, {size}) and finite{hint}, "
                                   f"got shape {weights.shape}")
        if np.any(weights <= 0):
            raise SolverInputError(f"{what} must be positive definite: diagonal entries must be > 0, got {weights}")
        return weights
    try:
        weights = check_matrix(weights, what, (size, size))
    except SolverInputError as exc:
        raise SolverInputError(f"{exc}{hint}") from None
    if np.max(np.abs(weights - weights.T)) > 1e-12 * np.abs(weights).max():
        raise SolverInputError(f"{what} must be symmetric")
    return weights


def free_floating_weights_note(n_arm: int) -> str:
    """What the weights of a free-floating (generalized-Jacobian) solve cover: the n_arm arm joints only."""
    return (f"free floating: the generalized Jacobian has one column per arm joint, so the weights cover the "
            f"{n_arm} arm joints only; the vehicle is not commanded, it moves by momentum conservation")


def check_variable_damping(epsilon: float, lambda_max: float) -> None:
    """The parameters of the variable damping (amundsen2018 eq. 6): epsilon > 0, lambda_max >= 0."""
    if not (np.isfinite(epsilon) and epsilon > 0 and np.isfinite(lambda_max) and lambda_max >= 0):
        raise SolverInputError("variable damping needs epsilon > 0 and "
                               f"lambda_max >= 0, got {epsilon!r}, {lambda_max!r}")


def check_choice(value: str, what: str, valid: tuple[str, ...]) -> str:
    """One of ``valid``; the message lists them."""
    if value not in valid:
        raise SolverInputError(f"unknown {what} {value!r}; valid: {', '.join(valid)}")
    return value


def apply_gain(gain: float | np.ndarray, error: np.ndarray) -> np.ndarray:
    """K e (k,) for a gain K given as a scalar, a diagonal (k,) or a matrix (k, k) [1/s], checked as
    :func:`gain_matrix` does.

    A scalar or diagonal K multiplies e entry by entry: the same numbers as K_matrix @ e (every other
    product is an exact zero), without building the matrix.
    """
    if isinstance(gain, (int, float)) and not isinstance(gain, bool):
        if not (math.isfinite(gain) and gain >= 0):
            raise SolverInputError(f"gain must be a finite scalar >= 0, ({error.size},) or ({error.size}, "
                                   f"{error.size}), got {gain!r}")
        return float(gain) * error
    gain_array = numbers(gain, f"gain must be a finite scalar >= 0, ({error.size},) "
                               f"or ({error.size}, {error.size}) [1/s]")
    if gain_array.ndim == 0:
        return apply_gain(float(gain_array), error)
    if gain_array.ndim == 1 and gain_array.shape == error.shape and np.all(gain_array >= 0) \
            and np.all(np.isfinite(gain_array)):
        return gain_array * error
    return gain_matrix(gain_array, error.size) @ error  # a matrix, or the message of a bad gain


def prepared_gain(gain: float | np.ndarray, size: int) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """(error e (size,), feedforward xdot_d (size,)) -> xdot_d + K e, K checked once for ``size`` rows.

    The products are those of :func:`apply_gain` (the same numbers), without its checks at every call.

    Raises:
        SolverInputError: a bad gain, as :func:`apply_gain` says it.
    """
    apply_gain(gain, np.zeros(size))
    if np.ndim(gain) == 0:
        scalar = float(gain)
        return lambda error, feedforward: feedforward + scalar * error
    array = np.asarray(gain, dtype=float)
    if array.ndim == 1:
        return lambda error, feedforward: feedforward + array * error
    matrix = gain_matrix(array, size)
    return lambda error, feedforward: feedforward + matrix @ error


def gain_matrix(gain: float | np.ndarray, size: int) -> np.ndarray:
    """The CLIK gain K as a (size, size) positive (semi-)definite matrix, from a scalar, a diagonal (size,) or a matrix
    [1/s]."""
    gain_array = numbers(gain, f"gain must be a finite scalar >= 0, ({size},) or ({size}, {size}) [1/s]")
    if gain_array.ndim == 0:
        gain_array = np.full(size, float(gain_array))
    if gain_array.ndim == 1:
        if gain_array.shape != (size,) or not np.all(np.isfinite(gain_array)) or np.any(gain_array < 0):
            raise SolverInputError(f"gain must be a finite scalar >= 0, ({size},) or ({size}, {size}), got {gain!r}")
        return np.diag(gain_array)
    if gain_array.shape != (size, size) or not np.all(np.isfinite(gain_array)):
        raise SolverInputError(f"gain must be a finite scalar, ({size},) or "
                               f"({size}, {size}), got shape {gain_array.shape}")
    symmetric = 0.5 * (gain_array + gain_array.T)
    if np.any(np.linalg.eigvalsh(symmetric) < 0):
        raise SolverInputError("gain K must be positive (semi-)definite")
    return gain_array
