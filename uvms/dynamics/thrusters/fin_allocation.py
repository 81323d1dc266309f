"""Thrusters and fins allocated together: the fins linearized about the step's velocity, as more columns of B.

A fin's wrench is nonlinear in its angle delta and grows with the square of the speed through the water (lift =
C_L(alpha) rho u^2 area / 2, :mod:`uvms.dynamics.thrusters.lift_drag`). At each control step the fins' wrench is
linearized in delta about the rest angles at the measured body velocity nu
(:meth:`uvms.dynamics.thrusters.fins.Fins.linearized`):

    w_fins(nu, delta) ~ w0(nu) + B_fins(u_r) (delta - delta_rest)

(w0: the fins' drag and lift at rest at nu; B_fins: the lift per radian at the surge through the water u_r,
proportional to u_r^2 below the stall; :meth:`FinAllocator.at` says why the surge alone). The
allocation then solves the same bounded problem as for thrusters alone
(:class:`uvms.dynamics.thrusters.allocation.ThrustAllocator`) on the columns [B | B_fins(nu)] for the wrench tau - w0,
the fins' variables bounded by their angle ranges: thrusts and fin angles are allocated together, with the same
priorities, least squares and least norm. The plant applies the true lift and drag of the angles reached
(:class:`uvms.dynamics.plant.actuated.ActuatedPlant`); what the linearization misses (the drag, even in delta, the
stall) is a disturbance the velocity loop's integral takes up. At rest the fins' columns are zero and the reachable
directions are the thrusters'; with speed, their lift adds directions (:meth:`FinAllocator.reach_note`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .allocation import TOLERANCE, AllocationResult, ThrustAllocator
from .fins import Fins

#: [m/s] the forward speed through the water at which ``uvms info`` and the layout warning state what the fins add.
REFERENCE_SPEED = 1.0
#: [m/s] below this surge through the water the fins get no column (their lift, ~u^2, is under 1 % of that at 1 m/s).
MIN_SPEED = 0.1


class FinAllocator:
    """The allocation of a body wrench to thrusters and fins at the vehicle's body velocity (module docstring).

    Args:
        matrix, lower, upper, priorities, weights, tolerance: the thrusters' B (6, n) and bounds (n,) [N], as
            :class:`~uvms.dynamics.thrusters.allocation.ThrustAllocator`.
        fins: the vehicle's fins (their angle ranges bound their variables; a fixed surface gets no column).

    Raises:
        SolverInputError: as ThrustAllocator.
    """

    def __init__(self, matrix: np.ndarray, lower: np.ndarray, upper: np.ndarray, fins: Fins, *,
                 priorities: Sequence[Sequence[str]] | None = None, weights: np.ndarray | None = None,
                 tolerance: float = TOLERANCE) -> None:
        self.thrusters = ThrustAllocator(matrix, lower, upper, priorities=priorities, weights=weights,
                                         tolerance=tolerance)  # checks the thrusters' data; the rest allocation
        self.fins = fins
        self.options = {"priorities": priorities, "weights": weights, "tolerance": tolerance}
        self.active = np.array([fin.moves for fin in fins.items], dtype=bool)
        bounds = np.array([fin.allocation_bounds for fin in fins.items]).reshape(-1, 2) - fins.held[:, None]
        self.lower = np.concatenate([self.thrusters.lower, bounds[self.active, 0]])
        self.upper = np.concatenate([self.thrusters.upper, bounds[self.active, 1]])

    @property
    def n(self) -> int:
        """The number of actuators: thrusters, then fins (the order of :attr:`AllocationResult.thrusts`)."""
        return self.thrusters.n + len(self.fins)

    def at(self, twist: np.ndarray, current: np.ndarray | None = None) -> tuple[ThrustAllocator, np.ndarray]:
        """(the allocator of thrusters and moving fins linearized at ``twist`` (6,) [m/s, rad/s] base frame, the fins'
        wrench at rest w0 (6,) [N, N m]); ``current`` (3,) [m/s] the water's velocity in the base frame (None: 0).

        w0 is the fins' wrench at the whole twist. Their columns are taken at the surge through the water alone,
        u_r = (twist - current)_x: the lift per radian at the speed (u_r^2), with the layout's own symmetry. Taken
        at the whole twist, the inflow of a small sway or yaw rate makes the columns of a symmetric cross differ in
        the fifth digit, and the allocation would reach the directions the fins cannot produce through four fins
        at their limits pushing against each other (the near-null pattern of the cross); below
        :data:`MIN_SPEED` the columns are zero: the fins are held at rest rather than swung to their limits for
        less than 1 % of the lift they give at 1 m/s."""
        twist = np.asarray(twist, dtype=float)
        water = np.zeros(3) if current is None else np.asarray(current, dtype=float)
        offset = self.fins.wrench(twist, water, self.fins.held)
        surge = float(twist[0] - water[0])
        columns = np.zeros((6, int(self.active.sum())))
        if abs(surge) >= MIN_SPEED:
            columns = self.fins.linearized(np.array([surge, 0.0, 0.0, 0.0, 0.0, 0.0]), np.zeros(3))[1][:, self.active]
        matrix = np.hstack([self.thrusters.matrix, columns])
        return ThrustAllocator(matrix, self.lower, self.upper, **self.options), offset

    def allocate(self, wrench: np.ndarray, twist: np.ndarray | None = None,
                 current: np.ndarray | None = None) -> AllocationResult:
        """The thrusts and fin angles for ``wrench`` (6,) [N, N m] at ``twist`` (None: at rest).

        Returns:
            An AllocationResult whose ``thrusts`` (n + m,) are the thrusts [N] then the fin angles [rad] (a fixed
            surface's at rest), ``achieved_wrench`` the linearized prediction B f + w0 + B_fins (delta - rest).
        """
        allocator, offset = self.at(np.zeros(6) if twist is None else twist, current)
        result = allocator.allocate(np.asarray(wrench, dtype=float) - offset)
        n = self.thrusters.n
        angles = self.fins.held.copy()
        angles[self.active] += result.thrusts[n:]
        saturated = np.zeros(len(self.fins), dtype=bool)
        saturated[self.active] = result.saturated[n:]
        return AllocationResult(np.concatenate([result.thrusts[:n], angles]),
                                np.concatenate([result.saturated[:n], saturated]), result.achieved_wrench + offset,
                                result.residual, result.attainable, result.solver)

    def reach_note(self, names: Sequence[str], speed: float = REFERENCE_SPEED) -> str:
        """What the thrusters cannot produce at rest and what, with the fins, at ``speed`` [m/s] forward ("" when the
        thrusters alone produce every direction)."""
        rest = self.thrusters.reach_note(names)
        if not rest or not self.active.any():
            return rest
        moving = [name for name, active in zip(self.fins.names, self.active) if active]
        allocator, _ = self.at(np.array([speed, 0.0, 0.0, 0.0, 0.0, 0.0]))
        gained = allocator.rank - self.thrusters.rank
        at_speed = allocator.reach_note([*names, *moving], actuators="thrusters and fins") or (
            "the thrusters and fins produce every body-wrench direction (rank 6)")
        return (f"at rest {rest}; at {speed:g} m/s forward through the water the {len(moving)} fins' lift adds "
                f"{gained} direction{'s' if gained != 1 else ''} (the lift grows with the speed squared, none at "
                f"rest): {at_speed}")


def thruster_count(allocator: ThrustAllocator | FinAllocator) -> int:
    """The thrusters among an allocation's variables (:attr:`AllocationResult.thrusts`: the thrusts [N] first, then a
    FinAllocator's fin angles [rad])."""
    return allocator.thrusters.n if isinstance(allocator, FinAllocator) else allocator.n
