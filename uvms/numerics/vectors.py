"""Small fixed-size vector arithmetic in Python floats, for the loops that handle one 3-vector at a time.

``numpy.cross`` spends about 5 us on its axis handling for two (3,) vectors; :func:`cross3` computes each
component as numpy does (two products and a difference), so its numbers are numpy's bit for bit.
"""

from __future__ import annotations

import numpy as np

__all__ = ["cross3"]


def cross3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b (3,) of two (3,) vectors: [a1 b2 - a2 b1, a2 b0 - a0 b2, a0 b1 - a1 b0], numpy.cross's numbers."""
    a0, a1, a2 = a.tolist()
    b0, b1, b2 = b.tolist()
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])
