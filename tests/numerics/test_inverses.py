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
