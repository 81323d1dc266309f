"""Hydrodynamic identification from a log: physically consistent Fossen parameters of the vehicle, with intervals.

:func:`identify` fits the vehicle's (root link's) added mass, linear and quadratic damping, volume and centre of
buoyancy to a log (:class:`uvms.dynamics.identification_data.IdentificationLog`) with the regression of
:mod:`uvms.dynamics.identification_model`: the arm's multibody effects and hydrodynamics, the rigid-body
inertia and the weights are known terms from the model (Pinocchio), so logs with a moving arm are usable.

The fit, in four steps
======================
1. **Smoothing**: Savitzky-Golay twist and accelerations (:func:`~uvms.dynamics.identification_data.smoothed_states`).
   The last ``holdout`` fraction of the log (default 20 %) is kept out of the fit, for the prediction check.
2. **Weights**: each wrench axis is weighted by 1 / sigma_a, sigma_a the RMS residual of that axis after an
   ordinary least-squares fit, at least ``noise_floor`` (1 %) of the RMS measured force (force axes) or
   moment (moment axes): the wrench is never trusted better than that.
3. **Identifiability**: the parameters are scaled by their scale
   (:func:`~uvms.dynamics.identification_model.parameter_layout`) and their standard errors computed (below),
   relative to the larger of the scale and the unconstrained estimate (a prior far too small does not hold a
   parameter the log determines well). While the largest relative standard error exceeds ``max_relative_error``
   (20 %), that parameter is held at its prior (the model's value) and the fit is repeated, so a parameter the
   log does not excite is reported as such and never fitted to noise.
4. **Constrained fit**: the weighted least squares with added mass symmetric positive semi-definite, damping
   coefficients >= 0 and volume > 0 (buoyancy positive), a convex problem solved by cvxpy with Clarabel.

Standard errors: the larger of two, per parameter: the Newey-West (heteroscedasticity and autocorrelation
consistent) sandwich covariance of the weighted least squares over the free parameters (Bartlett weights, a
bandwidth of two smoothing windows: the smoothing correlates neighbouring residuals), and the one residuals at the
noise floor would give with the samples of one window counted once (what a nearly noise-free log is still not
trusted better than: the model's own approximations, the smoothing's). The same standard error decides
identifiability (step 3) and gives the interval, +-1.96 standard errors (95 % under normal errors).

Errors in variables: the noise of the differentiated twist enters both the added-mass columns and, through the
known rigid-body inertia, the target, which would bias the added mass low; its expected share (from the noise
variance the smoothing estimates, :class:`~uvms.dynamics.identification_data.SmoothedStates`) is taken out of the
normal equations (bias-compensated least squares, :func:`~uvms.dynamics.identification_model.acceleration_noise_terms`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import IdentificationError, UVMSError
from .hydro_parameters import HydroParameters
from .hydrodynamics import hydrodynamics_of
from .identification_current import CurrentEstimate, checked_current, estimate_current
from .identification_data import IdentificationLog, smoothed_states
from .identification_model import (AXES, ParameterLayout, Regression, acceleration_noise_terms, identified_link_name,
                                   known_plant, link_from_theta, parameter_layout, regression, rigid_vehicle_mass)
from .identification_predict import HeldOutPrediction, predict_held_out

INSTALL_HINT = "identification needs cvxpy and Clarabel: pip install 'uvms[identify]' (cvxpy, clarabel)"
#: z of a two-sided 95 % interval.
Z95 = 1.959963984540054
#: How far [fraction of the range, at least 0.1 rad or m] a logged joint position may be outside the model's limits.
JOINT_LIMIT_MARGIN = 0.1


@dataclass(frozen=True)
class ParameterEstimate:
    """One identified (or held) parameter.

    Attributes:
        name, unit: e.g. "quadratic_damping[u]", "N s^2/m^2" (FLU axes, uvms's coefficients >= 0).
        prior: the model's value; value: the identified one (the prior when held).
        std_error: its standard error (None when held); interval: (low, high) +-1.96 standard errors (None).
        identified: False when held at the prior; reason: why it was held ("" when identified).
        relative_error: the standard error over the larger of the scale and the unconstrained estimate (what
            identifiability compares with ``max_relative_error``).
        scale: the parameter's scale (its prior's magnitude, at least a floor from the rigid-body mass:
            :func:`~uvms.dynamics.identification_model.parameter_layout`).
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
        log: the log (:class:`IdentificationLog`, e.g. from :func:`uvms.scenario.bag_reader.read_bag`).
        hydro: the prior hydrodynamics (None: the model's own, :func:`hydrodynamics_of`); every link but the
            vehicle's root link is taken as known.
        added_mass: "diagonal" (6 entries) or "full" (symmetric 6 x 6, 21 entries).
        current: (3,) the constant current [m/s], world ENU (None: the prior's): known, or where the search starts.
        identify_current: identify the current too (:mod:`uvms.dynamics.identification_current`), reported as
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
    theta_s, std_s, relative, reasons = _identifiable_fit(data, layout, weights, max_relative_error, states.window,
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
    solution = _normal_solve(regressor, data.target.ravel())[0]
    residual = data.target - (regressor @ solution).reshape(data.target.shape)
    sigma = np.sqrt(np.mean(residual ** 2, axis=0))
    for group in (slice(0, 3), slice(3, 6)):
        floor = noise_floor * np.sqrt(np.mean(wrench[:, group] ** 2))
        sigma[group] = np.maximum(sigma[group], max(floor, 1e-12))
    return 1.0 / sigma


def _identifiable_fit(data: Regression, layout: ParameterLayout, weights: np.ndarray, threshold: float,
                      window: int, prior_added: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[int, str]]:
    """Scaled theta, standard errors (scaled) and relative errors (p,), and {held parameter: reason} (module
    docstring)."""
    count = len(layout.scale)
    a = data.regressor * layout.scale * weights[None, :, None]  # (K, 6, p) scaled, weighted
    b = data.target * weights
    noise_gram, noise_moment = acceleration_noise_terms(layout, weights, data)
    noise_gram, noise_moment = len(b) * noise_gram, len(b) * noise_moment
    prior = layout.prior / layout.scale
    free = np.ones(count, dtype=bool)
    reasons: dict[int, str] = {}
    while True:
        columns = a[:, :, free]
        rhs = b - np.einsum("kap,p->ka", a[:, :, ~free], prior[~free])
        correction = (noise_gram[np.ix_(free, free)],
                      noise_moment[free] + noise_gram[np.ix_(free, ~free)] @ prior[~free])
        solution, covariance, floor_covariance, root = _least_squares(columns, rhs, 2 * window, correction)
        error, relative = np.full(count, np.nan), np.full(count, np.nan)
        error[free] = np.sqrt(np.maximum(np.diag(covariance), np.diag(floor_covariance) * window))
        # relative to the parameter's scale, or to its estimate when larger (a prior far too small holds nothing)
        relative[free] = error[free] / np.maximum(1.0, np.abs(solution))
        if not np.any(free) or np.nanmax(relative) <= threshold:
            break
        worst = int(np.nanargmax(relative))
        reasons[worst] = ("the log does not excite it above the odometry noise (no information)"
                          if not np.isfinite(relative[worst]) else
                          f"relative standard error {relative[worst]:.3g} > {threshold:g}: too little excitation")
        free[worst] = False
    theta = prior.copy()
    theta[free] = _constrained(root, layout, free, prior, solution, prior_added)
    return theta, error, relative, reasons


def _normal_solve(flat: np.ndarray, rhs: np.ndarray, correction: tuple[np.ndarray, np.ndarray] | None = None
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray]]:
    """Least squares of flat (m, p) x = rhs (m,) through the normal equations (the columns are scaled, so
    their conditioning is fine, and a (p, p) eigendecomposition is far cheaper than an SVD of the tall matrix),
    the noise's expected share ``correction`` = (gram (p, p), moment (p,)) taken out (bias compensation).

    Returns:
        x (p,); the inverse of the corrected normal matrix (p, p); the undetermined parameters (p,) bool (the
        largest component of each direction whose eigenvalue is below 1e-20 of the largest: no information, or
        the noise's share larger than the signal's); a square root (r (p, p),
        d (p,)) with x^T G x - 2 c^T x = |r x - d|^2 + const.
    """
    gram = flat.T @ flat
    moment = flat.T @ rhs
    if correction is not None:
        gram = gram - correction[0]
        moment = moment + correction[1]
    values, vectors = np.linalg.eigh(0.5 * (gram + gram.T))
    keep = values > 1e-20 * max(values[-1], 1e-300)
    inverse = np.where(keep, 1.0 / np.where(keep, values, 1.0), 0.0)
    solution = vectors @ (inverse * (vectors.T @ moment))
    undetermined = np.zeros(len(values), dtype=bool)  # each direction without information: its main parameter
    undetermined[np.argmax(np.abs(vectors[:, ~keep]), axis=0)] = True
    root = np.sqrt(np.maximum(values, 0.0))
    return (solution, (vectors * inverse) @ vectors.T, undetermined,
            (root[:, None] * vectors.T, np.where(keep, np.sqrt(inverse), 0.0) * (vectors.T @ moment)))


def _least_squares(a: np.ndarray, b: np.ndarray, bandwidth: int, correction: tuple[np.ndarray, np.ndarray]
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, tuple]:
    """Least squares of (K, 6, p) a against (K, 6) b (:func:`_normal_solve`): the solution, its Newey-West
    covariance, the inverse normal matrix (inf on the diagonal for the parameters the data leave
    undetermined) and the square root of the objective."""
    count = a.shape[2]
    if count == 0:
        return np.zeros(0), np.zeros((0, 0)), np.zeros((0, 0)), (np.zeros((0, 0)), np.zeros(0))
    solution, bread, undetermined, root = _normal_solve(a.reshape(-1, count), b.ravel(), correction)
    residual = b - np.einsum("kap,p->ka", a, solution)
    scores = np.einsum("kap,ka->kp", a, residual)  # (K, p)
    scores -= scores.mean(axis=0)  # the compensated noise share leaves a mean score
    meat = scores.T @ scores
    for lag in range(1, min(bandwidth, len(scores) - 1) + 1):
        gamma = scores[lag:].T @ scores[:-lag]
        meat += (1.0 - lag / (bandwidth + 1.0)) * (gamma + gamma.T)
    covariance = bread @ meat @ bread
    for matrix in (covariance, bread):
        matrix[undetermined, undetermined] = np.inf
    return solution, covariance, bread, root


def _constrained(root: tuple[np.ndarray, np.ndarray], layout: ParameterLayout, free: np.ndarray, prior: np.ndarray,
                 start: np.ndarray, prior_added: np.ndarray) -> np.ndarray:
    """The free scaled parameters minimising |r x - d|^2 (root = (r, d), the least squares' square root) with
    M_A PSD, damping >= 0, volume > 0 (cvxpy)."""
    try:
        import cvxpy as cp
    except ImportError:
        raise IdentificationError(INSTALL_HINT) from None
    r, d = root
    x = cp.Variable(int(np.sum(free)))
    theta = [x[int(np.sum(free[:k]))] if free[k] else prior[k] for k in range(len(prior))]
    kinds = layout.kinds
    constraints = [theta[k] >= 0 for k in range(len(prior)) if free[k] and kinds[k].endswith("damping")]
    constraints += [theta[k] >= 1e-9 for k in range(len(prior)) if free[k] and kinds[k] == "volume"]
    entries = {pair: k for pair, k in zip(layout.pairs, layout.indices("added_mass"))}
    if any(free[k] for k in entries.values()):
        matrix = cp.Variable((6, 6), symmetric=True)
        for i in range(6):
            for j in range(i, 6):
                k = entries.get((i, j))  # an entry not identified (a coupling of the diagonal form) keeps its prior
                constraints.append(matrix[i, j] == (theta[k] * layout.scale[k] if k is not None
                                                    else prior_added[i, j]))
        constraints.append(matrix >> 0)
    problem = cp.Problem(cp.Minimize(cp.sum_squares(r @ x - d)), constraints)
    x.value = start
    try:
        problem.solve(solver=cp.CLARABEL)
    except (cp.error.SolverError, ValueError) as exc:
        if "CLARABEL" in str(exc) and "not installed" in str(exc):
            raise IdentificationError(INSTALL_HINT) from None
        raise IdentificationError(f"the constrained fit failed ({exc})") from None
    if problem.status not in ("optimal", "optimal_inaccurate") or x.value is None:
        raise IdentificationError(f"the constrained fit did not converge (solver status {problem.status})")
    return np.asarray(x.value, dtype=float)


def _estimate(layout: ParameterLayout, k: int, value: float, std_scaled: float, relative: float,
              reason: str) -> ParameterEstimate:
    scale = layout.scale[k]
    if reason:
        return ParameterEstimate(layout.names[k], layout.units[k], float(layout.prior[k]), float(layout.prior[k]),
                                 None, None, False, reason, float(relative), float(scale))
    std = float(std_scaled * scale)
    return ParameterEstimate(layout.names[k], layout.units[k], float(layout.prior[k]), float(value), std,
                             (float(value - Z95 * std), float(value + Z95 * std)), True, "", float(relative),
                             float(scale))


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
