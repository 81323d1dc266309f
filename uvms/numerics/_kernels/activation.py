"""Activations of inequality objectives: the bell over a band and the reference rate (iCAT).

``uvms.tasks.objectives``: 0 inside the valid set, rising smoothly (a cosine bell, C1) or at once (a step)
to 1 across the band at its border.

The module imports numba, so it is loaded where a solver first uses it, not by ``import uvms``; its kernels
compile at their first call and are cached on disk (``cache=True``, see :mod:`uvms.numerics._kernels`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["activation_reference_into", "bell_into", "bell_value"]


@njit(cache=True)
def bell_value(depth: float, band: float, step: bool) -> float:
    """Activation in [0, 1] of a row ``depth`` inside its border over ``band`` > 0 (iCAT).

    depth <= 0 (on or outside the border): 1; depth >= band: 0; between: (1 + cos(pi depth / band)) / 2
    (the cosine bell, C1), or 1 (``step``: a hard switch).
    """
    ratio = depth / band
    if step:
        return 1.0 if ratio < 1.0 else 0.0
    return 0.5 * (1.0 + np.cos(np.pi * min(max(ratio, 0.0), 1.0)))


@njit(cache=True)
def bell_into(depth: np.ndarray, band: np.ndarray, step: bool, out: np.ndarray) -> None:
    """:func:`bell_value` of each row (k,), written to ``out`` (k,)."""
    for row in range(depth.size):
        out[row] = bell_value(depth[row], band[row], step)


@njit(cache=True)
def activation_reference_into(value: np.ndarray, bounds: np.ndarray, gain: float, step: bool, activation: np.ndarray,
                              reference: np.ndarray) -> None:
    """The activation and the reference rate (k,) of an inequality objective at x = ``value`` (k,).

    Each row answers to its nearer bound (the only one when the other is infinite): activation the bell of
    its depth inside that bound, reference gain (x* - x) with x* = lower + band or upper - band.

    Args:
        value: x (k,); bounds: (5, k) lower, upper, band, lower + band, upper - band; gain: [1/s];
        step: the hard switch instead of the cosine bell; activation, reference: (k,) written (views of a
            solver's stacked rows, or an objective's own arrays).
    """
    for row in range(value.size):
        lower, upper = bounds[0, row], bounds[1, row]
        near_lower = (value[row] - lower) <= (upper - value[row])
        depth = value[row] - lower if near_lower else upper - value[row]
        activation[row] = bell_value(depth, bounds[2, row], step)
        reference[row] = gain * ((bounds[3, row] if near_lower else bounds[4, row]) - value[row])
