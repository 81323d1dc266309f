"""The command of a hierarchy's equality level, xdot_d + K e with a scalar gain, written into a solver's stacked rows.

The numbers of :func:`uvms.numerics.checks.prepared_gain` for a scalar K (numpy's ``feedforward + K * error``: the
product, then the sum, entry by entry), without its two temporaries and the copy into the stack.

The module imports numba, so it is loaded where a solver is built, not by ``import uvms``; its kernel compiles at
its first call and is cached on disk (``cache=True``, see :mod:`uvms.numerics._kernels`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["command_into"]


@njit(cache=True)
def command_into(error: np.ndarray, feedforward: np.ndarray, gain: float, out: np.ndarray) -> None:
    """out = feedforward + gain * error (k,) [units of the task per s].

    Args:
        error: e (k,); feedforward: xdot_d (k,); gain: K >= 0 [1/s]; out: (k,) written (a view of the stack).
    """
    for row in range(out.size):
        out[row] = feedforward[row] + gain * error[row]
