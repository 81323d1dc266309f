"""The vector arithmetic of an RK4 step (:func:`uvms.numerics.integrate.rk4_step`).

A step of the actuated plant combines its stage rates in about twenty numpy operations on vectors of 11-20 numbers,
each dominated by its dispatch, and solves each stage's tangent rate xi' = dexp^-1 w; here a stage's tangent solve
and the next stage's arguments (or, after the last stage, the weighted sums) are one compiled call after Pinocchio's
``dIntegrate``. The solve is SciPy's dgesv (:mod:`.solve`), the numbers of ``scipy.linalg.lapack.dgesv`` that the
stages solved with before. Each entry is computed with the operations of the numpy expressions they replace, in their
order (no fused multiply-add: numba contracts nothing without ``fastmath``), so the numbers are the same bit for bit.
A kinematic run's state has no vector part: its loops over x run no iteration.

The module imports numba, so it is loaded at a run's first RK4 step; its kernels compile at their first call
and are cached on disk (``cache=True``, see :mod:`uvms.numerics._kernels`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .solve import dgesv_into

__all__ = ["stage_inputs_into", "tangent_stage_into", "tangent_sums_into", "weighted_sum_into"]


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


@njit(cache=True)
def tangent_stage_into(jacobian: np.ndarray, velocity: np.ndarray, h: float, x: np.ndarray, x_rate: np.ndarray,
                       q_rate: np.ndarray, xi: np.ndarray, x_stage: np.ndarray) -> int:
    """A stage's tangent rate q_rate = solve(dIntegrate, w) (nv,), then the next stage's arguments from it and the
    stage's x_rate (:func:`stage_inputs_into`).

    Args:
        jacobian: dIntegrate/dxi at the stage (nv, nv); velocity: the stage's w (nv,); h: the next stage's step [s];
        x: the step's vector part (m,); x_rate: the stage's (m,); q_rate, xi: (nv,) and x_stage: (m,) written.

    Returns:
        LAPACK's info (> 0: dIntegrate singular; nothing after the solve written).
    """
    info = dgesv_into(jacobian, velocity, q_rate, False)
    if info == 0:
        stage_inputs_into(h, q_rate, x, x_rate, xi, x_stage)
    return info


@njit(cache=True)
def tangent_sums_into(jacobian: np.ndarray, velocity: np.ndarray, h: float, k1q: np.ndarray, k2q: np.ndarray,
                      k3q: np.ndarray, k1x: np.ndarray, k2x: np.ndarray, k3x: np.ndarray, k4x: np.ndarray,
                      x: np.ndarray, k4q: np.ndarray, tangent: np.ndarray, x_next: np.ndarray) -> int:
    """The last stage's tangent rate k4q = solve(dIntegrate, w) (nv,), then the step's weighted sums
    (:func:`weighted_sum_into`): tangent = h (k1q + 2 k2q + 2 k3q + k4q) (nv,), x_next = x + h (k1x + ... + k4x) (m,).

    Args:
        jacobian, velocity: as :func:`tangent_stage_into`; h: dt / 6 [s]; k1q ... k3q: (nv,); k1x ... k4x: (m,);
        x: (m,); k4q, tangent: (nv,) and x_next: (m,) written.

    Returns:
        LAPACK's info, as :func:`tangent_stage_into`.
    """
    info = dgesv_into(jacobian, velocity, k4q, False)
    if info == 0:
        weighted_sum_into(h, k1q, k2q, k3q, k4q, None, tangent)
        weighted_sum_into(h, k1x, k2x, k3x, k4x, x, x_next)
    return info
