"""The fit of :func:`uvms.dynamics.identification.identify.identify`: weighted, bias-compensated least squares,
parameters the log does not determine held by their priors with their uncertainty carried into the others' intervals,
Newey-West standard errors, and the constrained solution.

Identifiability and the prior
=============================
The parameters are scaled by their scale s_k (:func:`~uvms.dynamics.identification.model.parameter_layout`),
x_k = theta_k / s_k. While the largest relative standard error of the parameters still free exceeds ``threshold``
(the standard error over the larger of the scale and the estimate: a prior far too small does not hold a parameter
the log determines well), that parameter is held and the fit is repeated without it, so a parameter the log does
not excite is reported as such and never fitted to noise. It is held at the combination of its prior, known to
within :data:`PRIOR_SCALES` of its scale, and the log's estimate of it when it was held (Gaussian, inverse-variance
weights; a log without information leaves the prior, and an added mass keeps its prior: the positive semi-definite
constraint couples it to the entries identified).

A held value is uncertain, and the free parameters depend on it: a sway linear damping of true 0 held exactly at a
prior of 2 N s/m moved the quadratic sway damping from 217 to 211 +- 3.5. The held parameters' variances are carried
into the free ones' as consider parameters (Schmidt): x_free depends on x_held through S = -G_ff^-1 G_fh (G the
normal matrix), and S diag(var_held) S^T adds to the free parameters' covariance. The same standard error decides
what is held next, so a parameter that leans on an uncertain held one may be held in turn.

Standard errors of the free parameters: the larger of two, per parameter: the Newey-West (heteroscedasticity and
autocorrelation consistent) sandwich covariance (Bartlett weights, a bandwidth of two smoothing windows: the
smoothing correlates neighbouring residuals), and the one residuals at the noise floor would give with the samples
of one window counted once (what a nearly noise-free log is still not trusted better than); plus the held
parameters' share.

Constrained fit: the free parameters' least squares with added mass symmetric positive semi-definite, damping
coefficients >= 0 and volume > 0 (buoyancy positive), a convex problem solved by cvxpy with Clarabel.
"""

from __future__ import annotations

import numpy as np

from ...errors import IdentificationError
from .model import ParameterLayout, Regression, acceleration_noise_terms

INSTALL_HINT = "identification needs cvxpy and Clarabel: pip install 'uvms[identify]' (cvxpy, clarabel)"
#: The prior's standard deviation, in units of the parameter's scale (its magnitude, or the floor of the scale), for a
#: parameter the log does not determine.
PRIOR_SCALES = 1.0


def identifiable_fit(data: Regression, layout: ParameterLayout, weights: np.ndarray, threshold: float, window: int,
                     prior_added: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[int, str]]:
    """Scaled theta, standard errors (scaled) and relative errors (p,), and {parameter held by its prior: reason}
    (module docstring).

    Args:
        data: the regression; layout: its parameters; weights: (6,) 1 / sigma per wrench axis.
        threshold: the largest relative standard error of a parameter the log determines; window: the smoothing
            window [samples]; prior_added: (6, 6) the prior added mass (its entries outside the layout are kept).
    """
    count = len(layout.scale)
    a = data.regressor * layout.scale * weights[None, :, None]  # (K, 6, p) scaled, weighted
    b = data.target * weights
    flat = a.reshape(-1, count)
    noise_gram, noise_moment = acceleration_noise_terms(layout, weights, data)
    gram = flat.T @ flat - len(b) * noise_gram  # the bias-compensated normal equations of every parameter
    moment = flat.T @ b.ravel() + len(b) * noise_moment
    values = layout.prior / layout.scale  # the held parameters' values, and their variances
    variances = np.zeros(count)
    free = np.ones(count, dtype=bool)
    relative = np.full(count, np.nan)
    reasons: dict[int, str] = {}
    while True:
        held = ~free
        solution, bread, undetermined, root = normal_solve(gram[np.ix_(free, free)],
                                                           moment[free] - gram[np.ix_(free, held)] @ values[held])
        residual = b - np.einsum("kap,p->ka", a[:, :, free], solution) - np.einsum("kap,p->ka", a[:, :, held],
                                                                                  values[held])
        sensitivity = -bread @ gram[np.ix_(free, held)]  # d x_free / d x_held
        consider = np.einsum("fh,h,fh->f", sensitivity, variances[held], sensitivity)
        variance = np.maximum(np.diag(_sandwich(a[:, :, free], residual, bread, 2 * window)), np.diag(bread) * window)
        error = np.full(count, np.nan)
        error[free] = np.where(undetermined, np.inf, np.sqrt(variance + consider))
        error[held] = np.sqrt(variances[held])
        # relative to the parameter's scale, or to its estimate when larger (a prior far too small holds nothing)
        current = np.full(count, -np.inf)
        current[free] = error[free] / np.maximum(1.0, np.abs(solution))
        if not np.any(free) or np.max(current) <= threshold:
            break
        worst = int(np.argmax(current))
        reasons[worst] = ("the log does not excite it above the odometry noise (no information)"
                          if not np.isfinite(current[worst]) else
                          f"relative standard error {current[worst]:.3g} > {threshold:g}: too little excitation")
        relative[worst] = current[worst]
        estimate = solution[int(np.sum(free[:worst]))]
        values[worst], variances[worst] = _posterior(layout.kinds[worst], values[worst], estimate, error[worst])
        free[worst] = False
    relative[free] = current[free]
    theta = values.copy()
    theta[free] = _constrained(root, layout, free, values, solution, prior_added)
    return theta, error, relative, reasons


def _posterior(kind: str, prior: float, estimate: float, error: float) -> tuple[float, float]:
    """The scaled value and variance of a parameter held by its prior (standard deviation PRIOR_SCALES) and the log's
    ``estimate`` +- ``error``; an added mass keeps its prior (the positive semi-definite constraint couples it to the
    entries identified), a damping is at least 0."""
    if kind == "added_mass" or not (np.isfinite(error) and error > 0):
        return prior, PRIOR_SCALES ** 2
    variance = 1.0 / (1.0 / PRIOR_SCALES ** 2 + 1.0 / error ** 2)
    value = variance * (prior / PRIOR_SCALES ** 2 + estimate / error ** 2)
    return (max(value, 0.0) if kind.endswith("damping") else value), variance


def normal_solve(gram: np.ndarray, moment: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray]]:
    """The minimiser of x^T G x - 2 c^T x (the normal equations G x = c of a least squares whose columns are scaled,
    so a (p, p) eigendecomposition is well conditioned and far cheaper than an SVD of the tall matrix).

    Returns:
        x (p,); the pseudo-inverse of G (p, p); the undetermined parameters (p,) bool (the largest component of
        each direction whose eigenvalue is below 1e-20 of the largest: no information, or the noise's share larger
        than the signal's); a square root (r (p, p), d (p,)) with x^T G x - 2 c^T x = |r x - d|^2 + const.
    """
    values, vectors = np.linalg.eigh(0.5 * (gram + gram.T))
    keep = values > 1e-20 * max(values[-1], 1e-300)
    inverse = np.where(keep, 1.0 / np.where(keep, values, 1.0), 0.0)
    solution = vectors @ (inverse * (vectors.T @ moment))
    undetermined = np.zeros(len(values), dtype=bool)  # each direction without information: its main parameter
    undetermined[np.argmax(np.abs(vectors[:, ~keep]), axis=0)] = True
    root = np.sqrt(np.maximum(values, 0.0))
    return (solution, (vectors * inverse) @ vectors.T, undetermined,
            (root[:, None] * vectors.T, np.where(keep, np.sqrt(inverse), 0.0) * (vectors.T @ moment)))


def _sandwich(a: np.ndarray, residual: np.ndarray, bread: np.ndarray, bandwidth: int) -> np.ndarray:
    """The Newey-West covariance (p, p) of a least-squares solution of (K, 6, p) a, its residual (K, 6) and the
    inverse of its normal matrix ``bread`` (p, p)."""
    scores = np.einsum("kap,ka->kp", a, residual)  # (K, p)
    scores -= scores.mean(axis=0)  # the compensated noise share leaves a mean score
    meat = scores.T @ scores
    for lag in range(1, min(bandwidth, len(scores) - 1) + 1):
        gamma = scores[lag:].T @ scores[:-lag]
        meat += (1.0 - lag / (bandwidth + 1.0)) * (gamma + gamma.T)
    return bread @ meat @ bread


def _constrained(root: tuple[np.ndarray, np.ndarray], layout: ParameterLayout, free: np.ndarray, values: np.ndarray,
                 start: np.ndarray, prior_added: np.ndarray) -> np.ndarray:
    """The free scaled parameters minimising |r x - d|^2 (root = (r, d), the least squares' square root, the held
    parameters at ``values``) with M_A PSD, damping >= 0, volume > 0 (cvxpy)."""
    try:
        import cvxpy as cp
    except ImportError:
        raise IdentificationError(INSTALL_HINT) from None
    r, d = root
    x = cp.Variable(int(np.sum(free)))
    theta = [x[int(np.sum(free[:k]))] if free[k] else values[k] for k in range(len(values))]
    kinds = layout.kinds
    constraints = [theta[k] >= 0 for k in range(len(values)) if free[k] and kinds[k].endswith("damping")]
    constraints += [theta[k] >= 1e-9 for k in range(len(values)) if free[k] and kinds[k] == "volume"]
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
