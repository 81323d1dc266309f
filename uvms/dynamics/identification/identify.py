"""Hydrodynamic identification from a log: physically consistent Fossen parameters of the vehicle, with intervals.

:func:`identify` fits the vehicle's (root link's) added mass, linear and quadratic damping, volume and centre of
buoyancy to a log (:class:`uvms.dynamics.identification.data.IdentificationLog`) with the regression of
:mod:`uvms.dynamics.identification.model`: the arm's multibody effects and hydrodynamics, the rigid-body
inertia and the weights are known terms from the model (Pinocchio), so logs with a moving arm are usable.

The fit, in four steps
======================
1. **Smoothing**: Savitzky-Golay twist and accelerations (:func:`~uvms.dynamics.identification.data.smoothed_states`).
   The last ``holdout`` fraction of the log (default 20 %) is kept out of the fit, for the prediction check.
2. **Weights**: each wrench axis is weighted by 1 / sigma_a, sigma_a the RMS residual of that axis after an
   ordinary least-squares fit, at least ``noise_floor`` (1 %) of the RMS measured force (force axes) or
   moment (moment axes): the wrench is never trusted better than that.
3. **Identifiability**: the parameters are scaled by their scale
   (:func:`~uvms.dynamics.identification.model.parameter_layout`) and their standard errors computed, relative to
   the larger of the scale and the estimate. While the largest relative standard error exceeds
   ``max_relative_error`` (20 %), that parameter is held by its prior (the model's value, known to within its
   scale, combined with the log's estimate) and the fit is repeated, its uncertainty carried into every other
   interval: a parameter the log does not excite is reported as such, never fitted to noise, and its prior biases
   no other parameter unseen (:mod:`uvms.dynamics.identification.fit`).
4. **Constrained fit**: the weighted least squares with added mass symmetric positive semi-definite, damping
   coefficients >= 0 and volume > 0 (buoyancy positive), a convex problem solved by cvxpy with Clarabel.

Standard errors (:mod:`uvms.dynamics.identification.fit`): the larger of the Newey-West sandwich covariance and the
one residuals at the noise floor would give with the samples of one window counted once. The same standard error
decides identifiability (step 3) and gives the interval, +-1.96 standard errors (95 % under normal errors).

Errors in variables: the noise of the differentiated twist enters both the added-mass columns and, through the
known rigid-body inertia, the target, which would bias the added mass low; its expected share (from the noise
variance the smoothing estimates, :class:`~uvms.dynamics.identification.data.SmoothedStates`) is taken out of the
normal equations (bias-compensated least squares, :func:`~uvms.dynamics.identification.model.acceleration_noise_terms`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...errors import IdentificationError, UVMSError
from ..hydro.hydrodynamics import hydrodynamics_of
from ..hydro.parameters import HydroParameters
from .current import CurrentEstimate, checked_current, estimate_current
from .data import IdentificationLog, smoothed_states
from .fit import PRIOR_SCALES, identifiable_fit, normal_solve
from .model import (
    AXES,
    ParameterLayout,
    Regression,
    identified_link_name,
    known_plant,
    link_from_theta,
    parameter_layout,
    regression,
    rigid_vehicle_mass,
)
from .predict import HeldOutPrediction, predict_held_out

#: z of a two-sided 95 % interval.
Z95 = 1.959963984540054
#: How far [fraction of the range, at least 0.1 rad or m] a logged joint position may be outside the model's limits.
JOINT_LIMIT_MARGIN = 0.1


@dataclass(frozen=True)
class ParameterEstimate:
    """One identified parameter, or one held by its prior (the log does not determine it).

    Attributes:
        name, unit: e.g. "quadratic_damping[u]", "N s^2/m^2" (FLU axes, uvms's coefficients >= 0).
        prior: the model's value; value: the identified one (held: the fit with the prior as a soft constraint,
            near the prior where the log holds no information).
        std_error: its standard error (None for a direction without any information); interval: (low, high)
            +-1.96 standard errors (None likewise). A held parameter's include its prior's uncertainty (one scale).
        identified: False when held by its prior; reason: why it was held ("" when identified).
        relative_error: the standard error over the larger of the scale and the estimate (what identifiability
            compares with ``max_relative_error``; a held parameter's when it was held).
        scale: the parameter's scale (its prior's magnitude, at least a floor from the rigid-body mass:
            :func:`~uvms.dynamics.identification.model.parameter_layout`).
    """

    name: str
    unit: str
    prior: float
    value: float
    std_error: float | None
    interval: tuple[float, float] | None
    identified: bool
    reason: str
    relative_error: float
    scale: float

    def as_dict(self) -> dict:
        """A JSON-ready mapping."""
        return {"name": self.name, "unit": self.unit, "prior": self.prior, "value": self.value,
                "std_error": self.std_error, "interval_95": None if self.interval is None else list(self.interval),
                "identified": self.identified, "held_because": self.reason or None,
                "relative_error": None if not np.isfinite(self.relative_error) else self.relative_error,
                "scale": self.scale}


@dataclass(frozen=True)
class IdentificationResult:
    """What :func:`identify` gives.

    Attributes:
        link: the identified link; parameters: one ParameterEstimate per parameter.
        hydro: the model's hydrodynamics with the identified link's parameters replaced.
        prior: the model's hydrodynamics as they were.
        metrics: fit metrics (RMS residuals per axis, fit % per axis on the held-out segment...).
        options: the options used; residual_t (K,), residuals (K, 6) [N, N m]: the fit's wrench residuals.
        prediction: measured and predicted twists on the held-out segment (None without one).
    """

    link: str
    parameters: tuple[ParameterEstimate, ...]
    hydro: HydroParameters
    prior: HydroParameters
    metrics: dict
    options: dict
    residual_t: np.ndarray
    residuals: np.ndarray
    prediction: HeldOutPrediction | None = field(default=None)

    def parameter(self, name: str) -> ParameterEstimate:
        """The estimate named ``name`` (e.g. "added_mass[u]").

        Raises:
            IdentificationError: an unknown name (the valid ones are listed).
        """
        for estimate in self.parameters:
            if estimate.name == name:
                return estimate
        raise IdentificationError(f"no parameter {name!r}; valid: {', '.join(p.name for p in self.parameters)}")

    def as_dict(self) -> dict:
        """The content of ``identification.json``."""
        held = {p.name: p.reason for p in self.parameters if not p.identified}
        return {"link": self.link, "conventions": "uvms: link frame FLU, [u v w p q r] about the link origin; "
                "damping coefficients >= 0; buoyancy_moment = volume * center_of_buoyancy",
                "parameters": [p.as_dict() for p in self.parameters], "held_at_prior": held,
                "metrics": self.metrics, "options": self.options}


def identify(robot, log: IdentificationLog, *, hydro: HydroParameters | None = None, added_mass: str = "diagonal",
             current: np.ndarray | None = None, identify_current: bool = False, window: float = 0.3,
             polyorder: int = 3, holdout: float = 0.2, max_relative_error: float = 0.2,
             noise_floor: float = 0.01) -> IdentificationResult:
    """Identify the vehicle's hydrodynamic parameters from a log (module docstring).

    Args:
        robot: the model (a floating-base :class:`uvms.Robot`); its URDF gives the known terms.
        log: the log (:class:`IdentificationLog`, e.g. from :func:`uvms.scenario.bags.reader.read_bag`).
        hydro: the prior hydrodynamics (None: the model's own, :func:`hydrodynamics_of`); every link but the
            vehicle's root link is taken as known.
        added_mass: "diagonal" (6 entries) or "full" (symmetric 6 x 6, 21 entries).
        current: (3,) the constant current [m/s], world ENU (None: the prior's): known, or where the search starts.
        identify_current: identify the current too (:mod:`uvms.dynamics.identification.current`), reported as
            the parameters current[x], current[y], current[z] and written into the hydrodynamics.
        window: Savitzky-Golay window [s]; polyorder: its order.
        holdout: the fraction of the log at its end kept for the prediction check, in [0, 0.5].
        max_relative_error: the largest relative standard error of an identified parameter, in (0, 1].
        noise_floor: the smallest relative wrench error assumed per axis group, in [0, 0.5].

    Raises:
        IdentificationError: a log that does not fit the model (joints), bad options, a fit that fails.
        UVMSError: a model without hydrodynamic parameters to start from.
    """
    options = _check_options(holdout, max_relative_error, noise_floor, added_mass)
    options.update(window_s=float(window), polyorder=int(polyorder), identify_current=bool(identify_current))
    prior = hydrodynamics_of(robot) if hydro is None else hydro
    link = identified_link_name(robot, prior)
    log = _arm_in_model_order(robot, log)
    fit_stop = len(log.t) - int(round(holdout * len(log.t)))
    states = smoothed_states(log.segment(0, fit_stop), window, polyorder)
    water = checked_current(prior.current if current is None else current,
                            f"the prior's current ({prior.source})" if current is None else "the current")
    found = None
    if identify_current:
        search = parameter_layout(prior.links[link], np.eye(6), added_mass)
        found = estimate_current(lambda c, s: regression(known_plant(robot, prior, link, c), search, s), search,
                                 states, water)
    plant = known_plant(robot, prior, link, water if found is None else found.value)
    data = regression(plant, parameter_layout(prior.links[link], np.eye(6), added_mass), states)
    layout = parameter_layout(prior.links[link], rigid_vehicle_mass(plant, data.q[0]), added_mass)
    weights = _axis_weights(data, states.wrench, layout, noise_floor)
    theta_s, std_s, relative, reasons = identifiable_fit(data, layout, weights, max_relative_error, states.window,
                                                         prior.links[link].added_mass)
    theta = theta_s * layout.scale
    try:
        identified = link_from_theta(layout, theta, prior.links[link])
    except UVMSError as exc:
        raise IdentificationError(f"the identified parameters are not physical ({exc})") from None
    result_hydro = HydroParameters(prior.fluid_density, prior.gravity, plant.hydro.current,
                                   {**prior.links, link: identified}, source=f"identified from {log.source}")
    residuals = data.target - np.einsum("kap,p->ka", data.regressor, theta)
    estimates = tuple(_estimate(layout, k, theta[k], std_s[k], relative[k], reasons.get(k, ""))
                      for k in range(len(theta))) + (() if found is None else _current_estimates(found))
    prediction = None
    if fit_stop < len(log.t):
        held_out = smoothed_states(log.segment(fit_stop, len(log.t)), window, polyorder)
        prediction = predict_held_out(robot, result_hydro, prior, plant.hydro.current, held_out)
    metrics = _metrics(data, residuals, states, prediction, log)
    return IdentificationResult(link, estimates, result_hydro, prior, metrics, options, states.t, residuals,
                                prediction)


def _check_options(holdout: float, max_relative_error: float, noise_floor: float, added_mass: str) -> dict:
    checks = (("holdout", holdout, 0.0, 0.5), ("max_relative_error", max_relative_error, 1e-6, 1.0),
              ("noise_floor", noise_floor, 0.0, 0.5))
    for name, value, low, high in checks:
        if not (isinstance(value, (int, float)) and low <= value <= high):
            raise IdentificationError(f"{name} must be a number in [{low:g}, {high:g}], got {value!r}")
    return {"holdout": holdout, "max_relative_error": max_relative_error, "noise_floor": noise_floor,
            "added_mass": added_mass, "interval": "+-1.96 Newey-West standard errors (95 %)",
            "derivatives": "Savitzky-Golay", "solver": "cvxpy + Clarabel"}


def _arm_in_model_order(robot, log: IdentificationLog) -> IdentificationLog:
    """The log with its joint columns in the order of ``robot.arm_joint_names``.

    Raises:
        IdentificationError: an arm joint of the model the log does not hold, or a joint position outside the
            model's limits by more than :data:`JOINT_LIMIT_MARGIN` of its range (at least 0.1 rad or m).
    """
    names = list(robot.arm_joint_names)
    missing = [name for name in names if name not in log.joint_names]
    if missing:
        raise IdentificationError(f"{log.source}: the log has no joint state for the arm joint(s) "
                                  f"{', '.join(missing)} of {robot.name} (it holds: "
                                  f"{', '.join(log.joint_names) or 'none'}); the arm's motion is a known term")
    order = [log.joint_names.index(name) for name in names]
    position = log.joint_position[:, order]
    lower, upper = robot.arm_limits
    margin = np.where(np.isfinite(upper - lower), np.maximum(JOINT_LIMIT_MARGIN * (upper - lower), 0.1), 0.0)
    outside = (position < lower - margin) | (position > upper + margin)
    if np.any(outside):
        k, j = (int(index[0]) for index in np.nonzero(outside))
        raise IdentificationError(f"{log.source}: joint {names[j]} is at {position[k, j]:.6g} in sample {k} "
                                  f"(t = {log.t[k]:.6g} s), outside its limits [{lower[j]:.6g}, {upper[j]:.6g}] in "
                                  f"{robot.name} (by more than {JOINT_LIMIT_MARGIN:.0%} of its range); the log is not "
                                  "of this model, or its joint states are not in its units")
    velocity = None if log.joint_velocity is None else log.joint_velocity[:, order]
    return IdentificationLog(log.t, log.position, log.quaternion, log.twist, log.wrench, tuple(names), position,
                             velocity, log.source)


def _axis_weights(data: Regression, wrench: np.ndarray, layout: ParameterLayout, noise_floor: float) -> np.ndarray:
    """1 / sigma_a (6,): the RMS residual of an ordinary least-squares fit per axis, floored (module docstring)."""
    regressor = (data.regressor * layout.scale).reshape(-1, len(layout.scale))
    solution = normal_solve(regressor.T @ regressor, regressor.T @ data.target.ravel())[0]
    residual = data.target - (regressor @ solution).reshape(data.target.shape)
    sigma = np.sqrt(np.mean(residual ** 2, axis=0))
    for group in (slice(0, 3), slice(3, 6)):
        floor = noise_floor * np.sqrt(np.mean(wrench[:, group] ** 2))
        sigma[group] = np.maximum(sigma[group], max(floor, 1e-12))
    return 1.0 / sigma


def _estimate(layout: ParameterLayout, k: int, value: float, std_scaled: float, relative: float,
              reason: str) -> ParameterEstimate:
    """The estimate of parameter k; one the log does not determine (``reason``) is not identified, its value and
    interval those of the fit with its prior as a soft constraint."""
    scale = layout.scale[k]
    std = float(std_scaled * scale)
    interval = (float(value - Z95 * std), float(value + Z95 * std)) if np.isfinite(std) else None
    return ParameterEstimate(layout.names[k], layout.units[k], float(layout.prior[k]), float(value),
                             std if np.isfinite(std) else None, interval, not reason,
                             f"{reason}; held by its prior (+-{PRIOR_SCALES:g} scale)" if reason else "",
                             float(relative), float(scale))


def _current_estimates(found: CurrentEstimate) -> tuple[ParameterEstimate, ...]:
    """current[x], current[y], current[z] [m/s] world ENU (scale 1 m/s)."""
    if found.std_error is None:
        return tuple(ParameterEstimate(f"current[{axis}]", "m/s", float(start), float(start), None, None, False,
                                       found.reason, np.inf, 1.0) for axis, start in zip("xyz", found.start))
    return tuple(ParameterEstimate(f"current[{axis}]", "m/s", float(start), float(value), float(std),
                                   (float(value - Z95 * std), float(value + Z95 * std)), True, "", float(std), 1.0)
                 for axis, start, value, std in zip("xyz", found.start, found.value, found.std_error))


def _metrics(data: Regression, residuals: np.ndarray, states, prediction: HeldOutPrediction | None,
             log: IdentificationLog) -> dict:
    """RMS wrench residuals and fraction of the wrench explained per axis; held-out fit % per axis."""
    rms = np.sqrt(np.mean(residuals ** 2, axis=0))
    spread = np.sqrt(np.mean((data.target - data.target.mean(axis=0)) ** 2, axis=0))
    metrics = {"log_duration_s": log.duration, "log_samples": len(log.t), "fit_samples": len(states.t),
               "smoothing_window_samples": states.window, "sample_step_s": states.dt,
               "wrench_residual_rms": dict(zip(AXES, rms.tolist())),
               "wrench_explained": dict(zip(AXES, (1.0 - rms ** 2 / np.maximum(spread ** 2, 1e-300)).tolist()))}
    if prediction is not None:
        metrics["held_out"] = prediction.metrics()
    return metrics
