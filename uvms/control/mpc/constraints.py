"""The scenario's inequality objectives as the MPC problem's constraints (or, with Box-FDDP, exact penalties).

Each objective of ``[[inequalities]]`` (:class:`uvms.tasks.objectives.base.Inequality`: joint limits, vehicle
attitude, plane clearance, obstacles, self-collision...) gives its rows x(q) (k,), their valid set lower <= x <= upper
and their Jacobian J (k, nv) (d x / dt = J v), from the objective itself: the collision distances and their
witness-point Jacobians are :class:`uvms.model.distances.PairDistances`' (coal), the same numbers the set-based chain
enforces. At a node with state x = (q, v) the rows are g = x(q) with dg/dq = J in Pinocchio's tangent space (``J v``
is the rate along v, and ``pin.integrate(q, dq)`` moves along dq: the same columns).

- **CSQP** (mim-solvers): the rows are inequality constraints lower <= g <= upper of the nodes 1..N (the first
  node's state is the measurement, which no input changes), and the inputs' bounds (thrusts, arm commands) are rows
  g = u of every running node (CSQP keeps no box of its own).
- **Box-FDDP**: the rows are the penalty w/2 |max(0, lower - g, g - upper)|^2 (quadratic outside the valid set,
  zero inside), the inputs' bounds the solver's box.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ...robot.configuration import Configuration
from ...robot.robot import Robot
from ...tasks.objectives.base import Inequality
from ...tasks.objectives.frames import VehicleAttitude

#: A bound CSQP treats as none (its ADMM takes finite numbers).
UNBOUNDED = 1.0e6
#: The directions (k, 2) of the tilt's rows: an octagon in the horizontal components of the vehicle's z axis.
TILT_DIRECTIONS = np.array([[np.cos(angle), np.sin(angle)] for angle in np.arange(4) * np.pi / 4])


class TiltRows:
    """The vehicle's tilt <= max_tilt as 4 rows for the MPC: the horizontal components (z_x, z_y) of the vehicle's
    z axis (world axes) along 4 directions d_k, |d_k . (z_x, z_y)| <= sin(max_tilt) cos(pi/8): the octagon inside
    the cone, so the tilt stays <= max_tilt (and >= 0.92 of it is allowed in every direction).

    The objective's own row, the tilt angle, has no gradient at level (its Jacobian there is taken as zero): a QP
    linearized at a level plan does not see the bound, and one SQP step may tilt past it. These rows are smooth
    there: d z_b/dt = omega x z_b.

    Args:
        objective: the scenario's vehicle-attitude objective (its frame, max_tilt and name).
    """

    collision = False

    def __init__(self, objective: VehicleAttitude) -> None:
        self.name, self.frame_id = objective.name, objective.frame_id
        bound = np.sin(objective.max_tilt) * np.cos(np.pi / 8)
        self.lower, self.upper = np.full(len(TILT_DIRECTIONS), -bound), np.full(len(TILT_DIRECTIONS), bound)

    def value_jacobian(self, state: Configuration) -> tuple[np.ndarray, np.ndarray]:
        """(rows (4,), their Jacobian (4, nv))."""
        z = state.pose(self.frame_id).rotation[:, 2]
        # d (z_x, z_y) / dt = (omega x z)[:2] = (z_z omega_y - z_y omega_z, z_x omega_z - z_z omega_x)
        rate = np.array([[0.0, z[2], -z[1]], [-z[2], 0.0, z[0]]])
        return TILT_DIRECTIONS @ z[:2], TILT_DIRECTIONS @ rate @ state.jacobian(self.frame_id)[3:]


def node_rows(objective: Inequality) -> Inequality | TiltRows:
    """An objective's rows in the MPC: the vehicle's attitude as :class:`TiltRows`, the others as they are."""
    return TiltRows(objective) if isinstance(objective, VehicleAttitude) else objective


class NodeConstraints:
    """The constraint rows of one node: the inputs' (running nodes) and the objectives' at the node's state.

    Args:
        robot: the model the objectives were built on; objectives: the scenario's inequality objectives.
        lower, upper: (nu,) the inputs' bounds, or None (no input rows: the terminal node, or Box-FDDP's box).
        with_state: whether the objectives' rows are in (False at the first node: its state is the measurement).
        margin: [m] added to the collision objectives' minimum distance in the prediction (what the plant loses
            between two solves: the inputs held, the thrusters' lag).
        scale: the objectives' rows are scaled by it (values, bounds, Jacobian) for CSQP's ADMM, whose penalty
            parameter is then in effect scale^2 times larger on them against the costs' Hessian.

    Attributes:
        ng: the number of rows; lower, upper: (ng,) their bounds (+-:data:`UNBOUNDED` for none).
    """

    def __init__(self, robot: Robot, objectives: Sequence[Inequality], lower: np.ndarray | None,
                 upper: np.ndarray | None, *, with_state: bool, margin: float = 0.0,
                 scale: float = 1.0) -> None:
        self.robot, self.scale = robot, float(scale)
        self.objectives = [node_rows(item) for item in objectives] if with_state else []
        self.nu = 0 if lower is None else len(lower)
        state_lower = [(item.lower + (margin if item.collision else 0.0)) * self.scale for item in self.objectives]
        state_upper = [item.upper * self.scale for item in self.objectives]
        bounds_lower = ([] if lower is None else [lower]) + state_lower
        bounds_upper = ([] if upper is None else [upper]) + state_upper
        self.lower = np.clip(np.concatenate(bounds_lower) if bounds_lower else np.zeros(0), -UNBOUNDED, UNBOUNDED)
        self.upper = np.clip(np.concatenate(bounds_upper) if bounds_upper else np.zeros(0), -UNBOUNDED, UNBOUNDED)
        self.ng = self.lower.size
        self.bounds = self.lower.copy(), self.upper.copy()  # the valid set, before any relaxation

    def configuration(self) -> Configuration:
        """A node's scratch configuration (its own Pinocchio data)."""
        return Configuration(self.robot, self.robot.neutral(), check=False)

    def state_rows(self, state: Configuration, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(the objectives' rows (k,), their Jacobian (k, nv)) at q (nq,), scaled."""
        state.update(q, check=False)
        values, jacobians = [], []
        for item in self.objectives:
            value, jacobian = item.value_jacobian(state)
            values.append(value)
            jacobians.append(jacobian)
        if not values:
            return np.zeros(0), np.zeros((0, self.robot.nv))
        return self.scale * np.concatenate(values), self.scale * np.vstack(jacobians)

    def relaxed(self, start: np.ndarray, fraction: float) -> tuple[np.ndarray, np.ndarray]:
        """The bounds (ng,) of this node when the measured state's rows ``start`` (k,, scaled) are outside the valid
        set: those rows' bounds moved from ``start`` towards the valid set's by ``fraction`` in [0, 1] (a path back
        over the first nodes, which the inputs can follow; a valid set out of reach at once makes the QP
        infeasible). Rows inside keep their bounds."""
        lower, upper = self.bounds[0].copy(), self.bounds[1].copy()
        rows = slice(self.nu, self.ng)
        lower[rows] = np.minimum(lower[rows], start + fraction * (lower[rows] - start))
        upper[rows] = np.maximum(upper[rows], start + fraction * (upper[rows] - start))
        return lower, upper

    def penalty(self, values: np.ndarray, jacobian: np.ndarray,
                weight: float) -> tuple[float, np.ndarray, np.ndarray]:
        """(cost, gradient (nv,), Gauss-Newton Hessian (nv, nv)) of weight/2 |violation|^2 of the objectives' rows
        ``values`` (k,) with their Jacobian (k, nv)."""
        lower, upper = self.lower[self.nu:], self.upper[self.nu:]
        below, above = values < lower, values > upper
        violation = np.where(below, values - lower, np.where(above, values - upper, 0.0))
        active = below | above
        rows = jacobian[active]
        return (0.5 * weight * float(violation @ violation), weight * (violation[active] @ rows),
                weight * (rows.T @ rows))
