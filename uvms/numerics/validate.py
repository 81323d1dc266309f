"""Input validation shared by every layer: arrays of numbers, positive numbers, time vectors.

Each function raises the error class its caller names (a subclass of `uvms.UVMSError`, e.g.
ConfigurationError for configurations, WorkspaceInputError for workspace arguments), with a message that
says what was wrong and what is valid.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..errors import UVMSError


def finite_array(value: object, what: str, shape: Sequence[int | None] | None = None, *,
                 error: type[UVMSError] = UVMSError, unit: str = "") -> np.ndarray:
    """``value`` as a float array of ``shape`` (None entries: any size) whose entries are all finite.

    Raises:
        error: not numbers, the wrong shape, or NaN/inf entries (their indices are named for vectors).
    """
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        size = shape[0] if shape is not None and len(shape) == 1 and shape[0] is not None else None
        expected = f"a vector of {size} numbers" if size is not None else "numbers"
        raise error(f"{what} must be {expected}{unit}, got {value!r}") from None
    if shape is not None and (array.ndim != len(shape)
                              or any(n is not None and n != m for n, m in zip(shape, array.shape))):
        expected = ", ".join("N" if n is None else str(n) for n in shape) + ("," if len(shape) == 1 else "")
        raise error(f"{what} must have shape ({expected}){unit}, got {array.shape}")
    if not np.all(np.isfinite(array)):
        where = f" at {np.flatnonzero(~np.isfinite(array)).tolist()}" if array.ndim == 1 else ""
        raise error(f"{what} has non-finite entries{where}")
    return array


def positive_number(value: object, what: str, *, allow_zero: bool = False, unit: str = "",
                    error: type[UVMSError] = UVMSError) -> float:
    """A finite real number > 0 (or >= 0), as a float; booleans and strings are refused.

    Raises:
        error: anything else.
    """
    number = value if isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool) else None
    if number is None or not np.isfinite(number) or number < 0 or (number == 0 and not allow_zero):
        bound = ">= 0" if allow_zero else "> 0"
        raise error(f"{what} must be a finite number {bound}{unit}, got {value!r}")
    return float(number)


def time_vector(times: object, what: str = "times", count: int | None = None, *, strict: bool = True,
                minimum: int = 1, error: type[UVMSError] = UVMSError) -> np.ndarray:
    """Finite times (m,) [s], strictly increasing (``strict``) or non-decreasing, ``count`` of them if given.

    Raises:
        error: not numbers, the wrong count, fewer than ``minimum``, non-finite or out of order.
    """
    array = finite_array(times, what, error=error, unit=" [s]").ravel()
    if count is not None and array.size != count:
        raise error(f"{what} needs {count} values, got {array.size}")
    steps = np.diff(array)
    if array.size < minimum or np.any(steps <= 0 if strict else steps < 0):
        order = "strictly increasing" if strict else "non-decreasing"
        raise error(f"{what} must be at least {minimum} finite, {order} values [s], got {array.tolist()[:8]}")
    return array
