"""The inverses every solver uses (uvms.numerics.inverses): the compiled SVD inverse against numpy's LAPACK."""

from __future__ import annotations

import numpy as np
import pytest

from uvms.errors import NumericalError
from uvms.numerics.inverses import RCOND, prepared_svd_inverse


def test_the_compiled_svd_inverse_is_numpy_svd_to_rounding(rng):
    """The one-sided Jacobi SVD of the kernel against LAPACK's (numpy): the same inverse and sigma_min to rounding."""
    for rows, columns in ((3, 6), (6, 11), (6, 12), (7, 5)):
        jacobian = rng.normal(size=(rows, columns))
        for damping in (0.0, 0.1):
            inverse, sigma_min, used = prepared_svd_inverse(jacobian, damping)
            u, singular, vt = np.linalg.svd(jacobian, full_matrices=False)
            if damping:
                factors = singular / (singular**2 + damping**2)
            else:
                factors = np.where(singular > RCOND * singular[0], 1.0 / singular, 0.0)
            assert np.allclose(inverse, (vt.T * factors) @ u.T, rtol=0, atol=1e-13 * np.abs(inverse).max())
            assert sigma_min == (pytest.approx(singular[-1], rel=1e-13) if rows <= columns else 0.0)
            assert used == damping
        if rows <= columns:
            assert np.allclose(jacobian @ prepared_svd_inverse(jacobian, 0.0)[0], np.eye(rows), atol=1e-12)
    with pytest.raises(NumericalError, match="did not converge"):
        prepared_svd_inverse(np.full((3, 6), np.nan), 0.0)


def numpy_weighted_dls(jacobian, weights, damping, command, z0):
    """x = W^-1/2 A^T (A A^T + l^2 I)^-1 (c - J z0) + z0, A = J W^-1/2 (W = L L^T: L^-T for a full W), by numpy."""
    transform = np.linalg.inv(np.linalg.cholesky(weights)).T if weights.ndim == 2 else np.diag(weights ** -0.5)
    scaled = jacobian @ transform
    normal = scaled @ scaled.T + damping ** 2 * np.eye(jacobian.shape[0])
    return transform @ scaled.T @ np.linalg.solve(normal, command - jacobian @ z0) + z0, scaled


def test_a_fixed_damping_solves_by_cholesky_and_computes_sigma_min_when_asked(rng):
    """A well-conditioned J L^-T with a fixed damping: the normal equations by Cholesky (sigma_min not computed:
    a function returns it, the SVD's number); the solution is numpy's DLS to rounding, for W = I, diagonal, full."""
    from uvms.numerics.inverses import WeightedInverse

    matrix = rng.normal(size=(12, 12))
    for weights in (np.ones(12), rng.uniform(0.5, 3.0, 12), matrix @ matrix.T + 12 * np.eye(12)):
        inverse = WeightedInverse(weights, 12)
        for _ in range(10):
            jacobian, command, z0 = rng.normal(size=(6, 12)), rng.normal(size=6), rng.normal(size=12)
            x, sigma_min, used = inverse.solve(jacobian, command, 0.05, z0)
            expected, scaled = numpy_weighted_dls(jacobian, weights, 0.05, command, z0)
            assert np.allclose(x, expected, rtol=0, atol=1e-13 * np.abs(expected).max()) and used == 0.05
            assert callable(sigma_min)  # computed when called
            singular = np.linalg.svd(scaled, compute_uv=False)
            assert sigma_min() == pytest.approx(singular[-1], rel=1e-13)
            _, svd_sigma, _ = inverse.solve(jacobian, command, 0.0, z0)  # undamped: the SVD's own sigma_min
            assert sigma_min() == svd_sigma  # the same rotations, bit for bit


def test_an_ill_conditioned_fixed_damping_solves_by_the_svd(rng):
    """J L^-T of nearly dependent rows: the Cholesky refuses (its pivots fall under 1e-4 of the diagonal), the
    SVD solves it and reports sigma_min at once; the numbers are numpy's SVD-based DLS."""
    from uvms.numerics.inverses import WeightedInverse

    jacobian = rng.normal(size=(6, 12))
    jacobian[5] = jacobian[4] + 1e-6 * rng.normal(size=12)  # sigma_min ~ 1e-6 |J|
    command = rng.normal(size=6)
    x, sigma_min, used = WeightedInverse(None, 12).solve(jacobian, command, 1e-3, None)
    u, singular, vt = np.linalg.svd(jacobian, full_matrices=False)
    expected = vt.T @ (singular / (singular ** 2 + 1e-6) * (u.T @ command))
    assert isinstance(sigma_min, float) and sigma_min == pytest.approx(singular[-1], rel=1e-9)
    # the small direction is known to eps |J| / sigma_min ~ 1e-10 by any SVD: LAPACK's and the Jacobi agree so far
    assert np.allclose(x, expected, rtol=0, atol=1e-9 * np.abs(expected).max()) and used == 1e-3
