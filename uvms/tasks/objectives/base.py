"""The inequality objective: a valid set lower <= x(q) <= upper instead of a target, and its activation.

An inequality objective (Simetti & Casalino's *inequality control objective*) gives, at a configuration,
its value x(q) (k,), its world-aligned Jacobian (k, nv) with xdot = J v, its valid set (per row a lower
and/or an upper bound, +-inf where there is none), an activation in [0, 1] per row and a reference rate
that pushes x back inside:

* activation: 0 deeper inside the valid set than ``band``, rising smoothly across the band to 1 at the
  border and staying 1 outside. The default ``"cosine"`` shape is the iCAT bell
  a(s) = (1 + cos(pi s)) / 2, s = (distance inside the border) / band, which is C1 (zero slope at both
  ends of the band); ``"step"`` (1 anywhere inside the band or beyond, else 0) is the hard switch that
  the smooth shape is compared with.
* reference: xdot_ref = gain (x* - x), x* the inner edge of the band (where the activation is 0) on the
  side of the nearer bound.

What the band costs: the set-based solver (:mod:`uvms.solvers.set_based`) lets the levels below use a
direction an objective holds only as far as its activation releases it, and with its eta term (default
eta = 1) keeps them off the part released, so a task pushing towards the border stops inside the band.
Measured (``tests/solvers/test_hierarchy_quality.py``): a UR5 tool point reaching 0.07 m beyond a wall kept
at ``min`` = 0.1 m, band 0.2 m, stops 0.197 m from the wall (a task error of 0.167 m against the geometric
0.070 m); the QP hierarchy, whose velocity damper has no band, reaches 0.100 m. ``solver.eta = 0`` lets
the task use the band: it reaches 0.101 m (0.071 m of error), at the price of the eta term's protection
against a level using a direction the levels above have only partly released (their activations between
0 and 1). A narrower band costs less (the task stops within it) but turns the objective on more abruptly.

The solvers read all of it at once through :meth:`Inequality.rows` (an :class:`InequalityRows`).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ...errors import ObjectiveError
from ...numerics._kernels import Kernel
from ...robot.configuration import Configuration
from ...robot.robot import Robot

#: Shapes of the activation across the band.
ACTIVATION_SHAPES = ("cosine", "step")


#: The compiled activation and reference (:func:`uvms.numerics._kernels.activation.activation_reference_into`,
#: numba loaded where an objective is first evaluated).
_ACTIVATION_KERNEL = Kernel("activation", "activation_reference_into")


def bell(depth: np.ndarray, band: np.ndarray, shape: str = "cosine") -> np.ndarray:
    """Activation (k,) in [0, 1] of rows ``depth`` [units of x] inside their border, over ``band`` (k,) > 0.

    depth <= 0 (on or outside the border): 1; depth >= band: 0; between: (1 + cos(pi depth / band)) / 2
    (``"cosine"``, C1) or 1 (``"step"``) (:func:`uvms.numerics._kernels.activation.bell_value`).
    """
    from ...numerics._kernels.activation import bell_into  # numba: loaded at the first use, not by ``import uvms``

    depth = np.atleast_1d(np.asarray(depth, dtype=float))
    out = np.empty(depth.shape)
    bell_into(depth.reshape(-1), np.broadcast_to(np.asarray(band, dtype=float), depth.shape).reshape(-1).copy(),
              shape == "step", out.reshape(-1))
    return out


@dataclass(slots=True)
class InequalityRows:
    """An inequality objective evaluated at one configuration (plain slots: built at every step of a solver).

    Attributes:
        name: the objective's name (as results report it).
        value: x(q) (k,).
        jacobian: d x / dt = J v, (k, nv) world-aligned, columns in the order of v.
        lower, upper: the valid set (k,), -inf / +inf where unbounded.
        activation: (k,) in [0, 1].
        reference: reference rate xdot_ref (k,) [units of x per s].
        gain: the reference gain [1/s].
        pairs: a collision objective's pair of each row (k,) (indices into its pairs), else None.
    """

    name: str
    value: np.ndarray
    jacobian: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    activation: np.ndarray
    reference: np.ndarray
    gain: float
    pairs: np.ndarray | None = None

    @property
    def violation(self) -> float:
        """How far x is outside its valid set (>= 0) [units of x]."""
        outside = np.maximum(self.lower - self.value, self.value - self.upper)
        return float(max(np.max(outside, initial=0.0), 0.0))

    def constraint(self) -> tuple[np.ndarray, np.ndarray]:
        """The valid set as velocity constraints G v >= b, G (m, nv), b (m,), one row per finite bound.

        x >= lower becomes J v >= gain (lower - x) and x <= upper becomes -J v >= gain (x - upper):
        inside the valid set x may approach a bound at a rate proportional to its distance; outside it
        must come back at that rate (a velocity damper).
        """
        low, high = np.isfinite(self.lower), np.isfinite(self.upper)
        rows = np.vstack([self.jacobian[low], -self.jacobian[high]])
        bounds = np.concatenate([self.gain * (self.lower[low] - self.value[low]),
                                 self.gain * (self.value[high] - self.upper[high])])
        return rows, bounds


class Inequality(ABC):
    """An objective with a valid set lower <= x(q) <= upper (k rows) instead of a target.

    Subclasses set their bounds with :meth:`_set_valid_set` in their constructor and give
    :meth:`value` and :meth:`jacobian`. What the rest of uvms asks of a kind of objective it reads from the class
    (never from an ``isinstance``), so a new kind is one class and one entry of
    :data:`uvms.tasks.objectives.INEQUALITY_TYPES`:

    * ``type_name``: its scenario ``[[inequalities]]`` ``type``;
    * ``unit``: the label of its value on figures (:meth:`shown` maps a value to it);
    * ``min_metric``: the ``metrics.json`` key of its smallest value over a run (None: none);
    * ``collision``: a collision objective (its nearest pairs are recorded, reported and drawn);
    * ``bounds_joint_positions``: it holds arm joint positions (``v_index``, ``hard_lower``, ``hard_upper``),
      which the solvers turn into joint bounds (the QP hierarchy) or free columns (the damping);
    * ``file_keys``: its table keys that name a file (resolved inside the scenario's folder).

    Attributes:
        name: how results name it.
        dim: number of rows k.
        lower, upper: the valid set (k,), +-inf where unbounded.
        band: width (k,) > 0 of the activation band inside each bound [units of x].
        gain: reference gain [1/s] > 0.
        shape: "cosine" (iCAT bell, C1) or "step" (hard switch, for comparison).
    """

    name: str
    dim: int
    lower: np.ndarray
    upper: np.ndarray
    band: np.ndarray
    gain: float
    shape: str
    type_name: str = ""
    unit: str = "value"
    min_metric: str | None = None
    collision: bool = False
    bounds_joint_positions: bool = False
    file_keys: tuple[str, ...] = ()

    def _set_valid_set(self, lower: np.ndarray, upper: np.ndarray, band: float | np.ndarray, gain: float,
                       shape: str) -> None:
        """Check and store the valid set, the band, the gain and the activation shape."""
        lower, upper = np.asarray(lower, dtype=float).reshape(-1), np.asarray(upper, dtype=float).reshape(-1)
        band = np.broadcast_to(np.asarray(band, dtype=float), lower.shape).astype(float)
        if np.any(np.isnan(lower)) or np.any(np.isnan(upper)) or np.any(lower >= upper):
            raise ObjectiveError(f"{self.name}: the valid set needs lower < upper, got {lower} and {upper}")
        if not np.all(np.isfinite(lower) | np.isfinite(upper)):
            raise ObjectiveError(f"{self.name}: every row needs a finite lower or upper bound, got {lower} and {upper}")
        if not np.all(np.isfinite(band)) or np.any(band <= 0):
            raise ObjectiveError(f"{self.name}: the activation band must be finite and > 0, got {band}")
        two_sided = np.isfinite(lower) & np.isfinite(upper)
        if np.any(2 * band[two_sided] > (upper - lower)[two_sided]):
            raise ObjectiveError(f"{self.name}: the band {band} is wider than half the valid set "
                                 f"[{lower}, {upper}]; take a band below half its width")
        if not (np.isfinite(gain) and gain > 0):
            raise ObjectiveError(f"{self.name}: the reference gain must be finite and > 0 [1/s], got {gain!r}")
        if shape not in ACTIVATION_SHAPES:
            raise ObjectiveError(f"{self.name}: unknown activation shape {shape!r}; valid: "
                                 f"{', '.join(ACTIVATION_SHAPES)}")
        self.lower, self.upper, self.band, self.gain, self.shape = lower, upper, band, float(gain), shape
        self.dim = lower.size
        # the rows' constants as the compiled activation takes them (5, k): lower, upper, band, and the inner
        # edges lower + band and upper - band where the activation falls to 0
        self._bounds = np.array([lower, upper, band, lower + band, upper - band])
        self._step = shape == "step"

    @abstractmethod
    def value(self, state: Configuration) -> np.ndarray:
        """x(q) (k,)."""

    @abstractmethod
    def jacobian(self, state: Configuration) -> np.ndarray:
        """dx/dt = J v: (k, nv), world-aligned."""

    def activation(self, value: np.ndarray) -> np.ndarray:
        """Activation (k,) in [0, 1] at x = ``value`` (k,): the bell of the nearer bound (the larger of the two)."""
        return self._activation_reference(value)[0]

    def reference(self, value: np.ndarray) -> np.ndarray:
        """Reference rate (k,): gain (x* - x), x* = lower + band or upper - band (the nearer side)."""
        return self._activation_reference(value)[1]

    def _activation_reference(self, value: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(activation (k,), reference (k,)) at x = ``value`` in one compiled call
        (:func:`uvms.numerics._kernels.activation.activation_reference_into`)."""
        activation, reference = np.empty(self.dim), np.empty(self.dim)
        kernel = _ACTIVATION_KERNEL.function or _ACTIVATION_KERNEL.load()
        kernel(np.ascontiguousarray(value, dtype=float), self._bounds, self.gain, self._step, activation, reference)
        return activation, reference

    def value_jacobian(self, state: Configuration) -> tuple[np.ndarray, np.ndarray]:
        """(x(q) (k,), J (k, nv)) at ``state``; an objective whose two share one computation gives both at once."""
        return self.value(state), self.jacobian(state)

    def rows(self, state: Configuration) -> InequalityRows:
        """Everything a solver reads, at ``state`` (the activation and reference as :meth:`_activation_reference`
        computes them, inline: the solvers call this for every objective at every step)."""
        return self._rows(*self.value_jacobian(state))

    def rows_into(self, state: Configuration, jacobian: np.ndarray, activation: np.ndarray,
                  reference: np.ndarray) -> InequalityRows:
        """:meth:`rows` written into a solver's stacked rows: J into ``jacobian`` (k, nv), the activation and the
        reference into ``activation`` and ``reference`` (k,) (views the rows returned keep: the same numbers as
        :meth:`rows`). A kind whose rows a kernel writes in place overrides it; any other is evaluated by
        :meth:`rows` and copied."""
        rows = self.rows(state)
        jacobian[:] = rows.jacobian
        activation[:] = rows.activation
        reference[:] = rows.reference
        return InequalityRows(self.name, rows.value, jacobian, self.lower, self.upper, activation, reference, self.gain,
                              rows.pairs)

    def _rows(self, value: np.ndarray, jacobian: np.ndarray, pairs: np.ndarray | None = None) -> InequalityRows:
        """The rows of x = ``value`` (k,) and J = ``jacobian`` (k, nv) (``pairs``: a collision objective's)."""
        activation, reference = np.empty(self.dim), np.empty(self.dim)  # the rows keep them
        return self._rows_of(np.ascontiguousarray(value, dtype=float), jacobian, activation, reference, pairs)

    def _rows_of(self, value: np.ndarray, jacobian: np.ndarray, activation: np.ndarray, reference: np.ndarray,
                 pairs: np.ndarray | None = None) -> InequalityRows:
        """The rows of x = ``value`` (k,) (float, contiguous) and J = ``jacobian`` (k, nv), the activation and the
        reference written into ``activation`` and ``reference`` (k,)."""
        kernel = _ACTIVATION_KERNEL.function or _ACTIVATION_KERNEL.load()
        kernel(value, self._bounds, self.gain, self._step, activation, reference)
        return InequalityRows(self.name, value, jacobian, self.lower, self.upper, activation, reference, self.gain,
                              pairs)

    def shown(self, value: np.ndarray) -> np.ndarray:
        """A value (..., k) in the units figures draw it in (:attr:`unit`): its own, unless a kind says otherwise."""
        return value

    def row_names(self) -> list[str]:
        """A name per row (k,): its ``names`` (e.g. joints) when it has one per row, else its name (indexed)."""
        names = getattr(self, "names", None)
        if names is not None and len(names) == self.dim:
            return list(names)
        return [self.name] if self.dim == 1 else [f"{self.name}[{row}]" for row in range(self.dim)]

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r}, dim={self.dim})"


def vehicle_frame_id(robot: Robot, what: str) -> int:
    """The frame of the vehicle body (the body its floating/planar joint carries).

    Raises:
        ObjectiveError: a fixed base (no vehicle).
    """
    if robot.base_type == "fixed":
        raise ObjectiveError(f"{what} needs a vehicle, but {robot.name} has a fixed base; load it with "
                             f"base='floating' or 'planar', or name a frame")
    for index, frame in enumerate(robot.model.frames):
        if frame.parentJoint == 1 and frame.type == pin.FrameType.BODY:
            return index
    return robot.model.getFrameId(robot.model.names[1])


def finite_number(value: object, what: str, *, positive: bool = False) -> float:
    """A finite float (> 0 when ``positive``), else ObjectiveError naming ``what``."""
    try:
        number = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise ObjectiveError(f"{what} must be a number, got {value!r}") from None
    if isinstance(value, bool) or not np.isfinite(number) or (positive and number <= 0):
        raise ObjectiveError(f"{what} must be a finite number{' > 0' if positive else ''}, got {value!r}")
    return number
