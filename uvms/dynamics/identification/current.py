"""A constant ocean current identified with the vehicle's parameters
(:func:`uvms.dynamics.identification.identify.identify` with ``identify_current``).

The current v_c (3,) [m/s, world ENU] enters the equations of motion through the relative twist
nu_r = nu - [R^T v_c; 0] of every link's hydrodynamics, so the regression is linear in the parameters theta but not
in v_c. Variable projection: v_c minimises the residual left by the least-squares theta of that v_c,

    min over v_c of | W (target(v_c) - Phi(v_c) theta^(v_c)) |^2,   theta^(v_c) the weighted least squares,

solved by ``scipy.optimize.least_squares`` (trust region, finite-difference Jacobian in v_c) on every
:data:`STRIDE`-th sample of the smoothed log (the smoothing window correlates neighbours anyway). W weights each axis
by 1 / the RMS of its measured wrench. The parameters are then fitted on every sample with v_c held (the four
steps of :mod:`uvms.dynamics.identification.identify`). The current's standard error is that of the Gauss-Newton
linearisation at the optimum, theta and v_c together, the residual variance from the fit: the current is
identifiable when the vehicle turns (the current's direction in the body axes changes) and moves at several speeds.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ...errors import IdentificationError
from .data import SmoothedStates
from .model import ParameterLayout, Regression

#: Every STRIDE-th sample enters the search for the current.
STRIDE = 4
#: A current whose standard error is above this [m/s] is not determined by the log: held at its start.
MAX_CURRENT_ERROR = 0.05
#: The fastest current [m/s] given or identified (the strongest tidal streams run at about 5 m/s).
MAX_CURRENT_SPEED = 10.0


def checked_current(current: object, what: str) -> np.ndarray:
    """``current`` as (3,) [m/s] world ENU, finite, at most :data:`MAX_CURRENT_SPEED`.

    Raises:
        IdentificationError: not three finite numbers, or faster than MAX_CURRENT_SPEED.
    """
    try:
        value = np.array(current, dtype=float).reshape(3)
    except (TypeError, ValueError):
        raise IdentificationError(f"{what} must be three numbers [m/s] (world ENU), got {current!r}") from None
    if not (np.all(np.isfinite(value)) and np.linalg.norm(value) <= MAX_CURRENT_SPEED):
        raise IdentificationError(f"{what} must be finite and at most {MAX_CURRENT_SPEED:g} m/s (world ENU), got "
                                  f"{np.array2string(value, precision=4)}")
    return value


@dataclass(frozen=True)
class CurrentEstimate:
    """The identified current: value (3,) [m/s] world ENU, standard error (3,) [m/s] (None when held), start (3,)
    (the prior's or the given one), reason it was held ("" when identified), evaluations of the regression."""

    value: np.ndarray
    std_error: np.ndarray | None
    start: np.ndarray
    reason: str
    evaluations: int


def strided(states: SmoothedStates, stride: int) -> SmoothedStates:
    """Every ``stride``-th sample of the smoothed log (its per-sample arrays sliced, the rest kept)."""
    count = len(states.t)
    return dataclasses.replace(states, **{field.name: getattr(states, field.name)[::stride]
                                          for field in dataclasses.fields(states)
                                          if isinstance(getattr(states, field.name), np.ndarray)
                                          and getattr(states, field.name).shape[:1] == (count,)})


def estimate_current(regression_of: Callable[[np.ndarray, SmoothedStates], Regression], layout: ParameterLayout,
                     states: SmoothedStates, start: np.ndarray) -> CurrentEstimate:
    """The current minimising the variable-projection residual (module docstring).

    Args:
        regression_of: (current (3,), states) -> the regression with that current.
        layout: the parameters (their columns are scaled by their norms here); states: the smoothed fit segment.
        start: (3,) [m/s] where the search starts.

    Raises:
        IdentificationError: the search fails (scipy's message).
    """
    from scipy.optimize import least_squares

    sparse = strided(states, STRIDE)
    weights = 1.0 / np.maximum(np.sqrt(np.mean(states.wrench ** 2, axis=0)), 1e-12)  # (6,)
    count = [0]

    def system(current: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        count[0] += 1
        data = regression_of(current, sparse)
        a = (data.regressor * weights[None, :, None]).reshape(-1, data.regressor.shape[2])
        return a, (data.target * weights).ravel()

    def residual(current: np.ndarray) -> np.ndarray:
        a, b = system(current)
        return b - a @ np.linalg.lstsq(a, b, rcond=None)[0]

    try:
        found = least_squares(residual, np.asarray(start, dtype=float), x_scale=0.1, diff_step=1e-4)
    except (ValueError, np.linalg.LinAlgError) as exc:
        raise IdentificationError(f"the search for the current failed ({exc})") from None
    # neighbours within a smoothing window are correlated: about one independent sample per window, not per stride
    error = _standard_error(system, found.x, len(layout.scale)) * np.sqrt(max(states.window / STRIDE, 1.0))
    if not np.all(np.isfinite(error)) or np.max(error) > MAX_CURRENT_ERROR or \
            not np.linalg.norm(found.x) <= MAX_CURRENT_SPEED:
        shown = "undetermined" if not np.all(np.isfinite(error)) else f"{np.max(error):.3g} m/s"
        return CurrentEstimate(np.asarray(start, dtype=float), None, np.asarray(start, dtype=float),
                               f"the log does not determine it (standard error {shown} > {MAX_CURRENT_ERROR:g} m/s; "
                               "the vehicle must turn and change speed)", count[0])
    return CurrentEstimate(found.x, error, np.asarray(start, dtype=float), "", count[0])


def _standard_error(system: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]], current: np.ndarray,
                    parameters: int) -> np.ndarray:
    """(3,) [m/s]: Gauss-Newton standard errors of the current, theta and v_c linearised together."""
    a, b = system(current)
    theta = np.linalg.lstsq(a, b, rcond=None)[0]
    step = 1e-4
    columns = []
    for axis in np.eye(3):
        a_step, b_step = system(current + step * axis)
        columns.append(((b_step - a_step @ theta) - (b - a @ theta)) / step)  # d residual / d v_c
    jacobian = np.hstack([-a, -np.column_stack(columns)])
    residual = b - a @ theta
    variance = residual @ residual / max(len(b) - parameters - 3, 1)
    scale = np.maximum(np.linalg.norm(jacobian, axis=0), 1e-300)
    gram = (jacobian / scale).T @ (jacobian / scale)
    try:
        covariance = np.linalg.inv(gram) / np.outer(scale, scale) * variance
    except np.linalg.LinAlgError:
        return np.full(3, np.inf)
    return np.sqrt(np.maximum(np.diag(covariance)[-3:], 0.0))
