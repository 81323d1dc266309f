"""The 3-vector cross product: numpy's numbers, bit for bit."""

from __future__ import annotations

import numpy as np

from uvms.numerics.vectors import cross3


def test_cross3_is_numpys_cross_bit_for_bit_and_the_right_handed_product():
    rng = np.random.default_rng(3)
    scales = 10.0 ** rng.integers(-8, 8, size=(4000, 2, 1))  # magnitudes where rounding differs between formulas
    pairs = rng.normal(size=(4000, 2, 3)) * scales
    for a, b in pairs:
        assert cross3(a, b).tobytes() == np.cross(a, b).tobytes()
    x, y, z = np.eye(3)
    assert cross3(x, y).tolist() == z.tolist() and cross3(y, x).tolist() == (-z).tolist()
    assert cross3(y, z).tolist() == x.tolist() and cross3(z, x).tolist() == y.tolist()
