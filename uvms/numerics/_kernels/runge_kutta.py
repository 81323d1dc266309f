"""The vector arithmetic of an RK4 step (:func:`uvms.numerics.integrate.rk4_step`) of a state with a vector part.

A step of the actuated plant combines its stage rates in about twenty numpy operations on vectors of 11-20 numbers,
each dominated by its dispatch; here they are two kinds of compiled call. Each entry is computed with the operations
of the numpy expressions they replace, in their order (no fused multiply-add: numba contracts nothing without
``fastmath``), so the numbers are the same bit for bit.

The module imports numba, so it is loaded where a plant is first integrated; its kernels compile at their first call
and are cached on disk (``cache=True``, see :mod:`uvms.numerics._kernels`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["stage_inputs_into", "weighted_sum_into"]


@njit(cache=True)
def stage_inputs_into(h: float, q_rate: np.ndarray, x: np.ndarray, x_rate: np.ndarray, xi: np.ndarray,
                      x_stage: np.ndarray) -> None:
    """A stage's arguments: xi = h q_rate (nv,) and x_stage = x + h x_rate (m,) (numpy's ``h * a`` and
    ``x + h * b``)."""
    for i in range(q_rate.size):
        xi[i] = h * q_rate[i]
    for i in range(x.size):
        x_stage[i] = x[i] + h * x_rate[i]


@njit(cache=True)
def weighted_sum_into(h: float, k1: np.ndarray, k2: np.ndarray, k3: np.ndarray, k4: np.ndarray, x: np.ndarray,
                      out: np.ndarray) -> None:
    """out = x + h (k1 + 2 k2 + 2 k3 + k4) (numpy's ``x + h * (k1 + 2.0 * k2 + 2.0 * k3 + k4)``, its sums left to
    right); x None: out = h (k1 + 2 k2 + 2 k3 + k4)."""
    for i in range(out.size):
        total = h * (((k1[i] + 2.0 * k2[i]) + 2.0 * k3[i]) + k4[i])
        out[i] = total if x is None else x[i] + total
