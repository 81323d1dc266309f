"""Objectives tightened by the measured tracking error: the actuated chain's inequalities kept on the measured state.

On the actuated plant the solver enforces an inequality objective on its *command*: the velocity it asks keeps
lower <= x(q) <= upper if the robot follows it over the step. The robot does not quite: the vehicle accelerates
within the step while the arm was solved for its velocity at the step's start, the arm's servos reach their rate
at the step's end (their lag compensated, :func:`uvms.dynamics.plant.actuated.lag_command`) so the step's mean rate
falls short, and the velocity loop trails a reference it cannot follow. Per step k, for each enforced objective
and each side of its valid set, the shortfall is how much nearer the bound the measured value came than the
command predicted::

    slack(x) = min over the rows of (x - lower)            (upper - x on the upper side)
    s_k = max(0, slack(x_{k-1} + J_{k-1} v_{k-1} dt) - slack(x_k))

v_{k-1} the velocity the hierarchy asked (the measured vehicle velocity and the arm's re-solved rates). The
velocity damper brings x back at the objective's gain g (x approaches a bound at g times its distance), so a
shortfall repeated every step leaves x short of the bound by s / (g dt) in steady state; the margin is that sum,
decaying at the same rate::

    m_k = exp(-g dt) m_{k-1} + s_k,   lower -> lower + m_k,  upper -> upper - m_k   (capped: see MAX_SHARE)

and the solver sees the bound moved inward by m_k for the step (the objective's own bounds are restored after it:
recorders and metrics read the nominal valid set). A loop that follows leaves m = 0; a loop that trails moves the
bound by what it trails by.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..robot.configuration import Configuration
from ..tasks.objectives.base import Inequality

#: The largest margin, as a share of the objective's band: the band is where the activation rises, so the bound
#: stays a band's width inside the nominal valid set at most (a two-sided set keeps a valid interval too).
MAX_SHARE = 1.0


class Tightening:
    """The margins of ``objectives`` from the measured state and the command, applied around each solve.

    Args:
        objectives: the enforced inequality objectives (their bounds are moved for a solve and restored after).
    """

    def __init__(self, objectives: Sequence[Inequality]) -> None:
        self.objectives = list(objectives)
        self._nominal = [(o.lower.copy(), o.upper.copy(), o.band.copy(), o.gain, o.shape) for o in self.objectives]
        self.reset()

    def reset(self) -> None:
        """Zero the margins, forget the last prediction."""
        self.margins = np.zeros((len(self.objectives), 2))  # [lower side, upper side] per objective [its unit]
        self._values: list[tuple[np.ndarray, np.ndarray]] = []  # (x, J) at the measured state of this step
        self._predicted: tuple[float, list[tuple[np.ndarray, np.ndarray]]] | None = None  # (t, [(x, J v)])
        self._moved = False  # bounds moved since the last restore

    def measure(self, t: float, configuration: Configuration) -> None:
        """Evaluate every objective at the measured state, update the margins from the last prediction and move
        the bounds inward by them (until :meth:`restore`)."""
        self._values = [objective.value_jacobian(configuration) for objective in self.objectives]
        if self._predicted is not None and t > self._predicted[0]:
            last, rates = self._predicted
            dt = t - last
            for index, ((value, _), (before, rate)) in enumerate(zip(self._values, rates)):
                lower, upper, _, gain, _ = self._nominal[index]
                predicted = _slack(before + rate * dt, lower, upper)  # at x_{k-1} + J_{k-1} v_{k-1} dt
                measured = _slack(value, lower, upper)
                bounded = np.isfinite(measured)  # a side without a bound has no shortfall (and no inf - inf)
                shortfall = np.where(bounded, np.maximum(0.0, np.where(bounded, predicted, 0.0)
                                                         - np.where(bounded, measured, 0.0)), 0.0)
                self.margins[index] = np.exp(-gain * dt) * self.margins[index] + shortfall
        for index, objective in enumerate(self.objectives):
            lower, upper, band, gain, shape = self._nominal[index]
            cap = MAX_SHARE * float(np.min(band))
            two_sided = np.isfinite(lower) & np.isfinite(upper)
            if np.any(two_sided):  # keep 2 band < upper - lower after the move
                cap = min(cap, max(0.0, 0.5 * (float(np.min((upper - lower)[two_sided] - 2.0 * band[two_sided]))
                                               - 1e-9)))
            low, high = np.minimum(self.margins[index], cap)
            if low > 0.0 or high > 0.0:
                objective._set_valid_set(lower + low, upper - high, band, gain, shape)
                self._moved = True

    def predict(self, t: float, v: np.ndarray) -> None:
        """Keep (x, J v) of each objective under the reference velocity v (nv,) for the next :meth:`measure`."""
        self._predicted = (t, [(value, jacobian @ v) for value, jacobian in self._values])

    def restore(self) -> None:
        """The objectives' nominal bounds back."""
        if self._moved:
            for objective, (lower, upper, band, gain, shape) in zip(self.objectives, self._nominal):
                objective._set_valid_set(lower, upper, band, gain, shape)
            self._moved = False


def _slack(value: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """[min over the rows of value - lower, min of upper - value] (2,) (inf on a side without a finite bound)."""
    low, high = np.isfinite(lower), np.isfinite(upper)
    return np.array([np.min(value[low] - lower[low], initial=np.inf),
                     np.min(upper[high] - value[high], initial=np.inf)])
