"""numpy_solve: numpy.linalg.solve's numbers without its wrapper, a vector or a matrix right-hand side."""

from __future__ import annotations

import numpy as np
import pytest

from uvms.errors import NumericalError
from uvms.numerics.lapack import numpy_solve


def test_numpy_solve_gives_numpys_numbers_for_a_vector_and_a_matrix_and_refuses_a_singular_system():
    rng = np.random.default_rng(11)
    for size, columns in ((3, 1), (6, 5), (6, 6), (11, 4)):
        matrix = rng.normal(size=(size, size))
        vector, block = rng.normal(size=size), rng.normal(size=(size, columns))
        assert numpy_solve(matrix, vector).tobytes() == np.linalg.solve(matrix, vector).tobytes()
        assert numpy_solve(matrix, block).tobytes() == np.linalg.solve(matrix, block).tobytes()
        np.testing.assert_allclose(matrix @ numpy_solve(matrix, block), block, atol=1e-9)
    singular = np.ones((3, 3))
    with np.errstate(invalid="ignore"), pytest.raises(NumericalError, match="singular"):
        numpy_solve(singular, np.ones((3, 2)))
    with np.errstate(invalid="ignore"), pytest.raises(NumericalError, match="singular"):
        numpy_solve(singular, np.ones(3))
