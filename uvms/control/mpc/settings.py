"""The whole-body MPC's settings: horizon, node step, solver iterations, the costs' weights and the bounds' margins.

Kept apart from the Crocoddyl code so that a scenario can be checked, and its settings read, without Crocoddyl.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from ...errors import UVMSError

#: The solvers: mim-solvers' constrained SQP (the objectives as constraints) or Crocoddyl's Box-FDDP (as penalties).
SOLVERS = ("csqp", "box_fddp")
#: The integrators of the prediction: Crocoddyl's symplectic Euler (one evaluation per node) or its RK4 (four).
INTEGRATORS = ("euler", "rk4")


@dataclass(frozen=True)
class MPCSettings:
    """What the MPC solves each control step.

    Attributes:
        horizon: the number of nodes N (>= 1); the horizon is N * node_dt [s].
        node_dt: the step between nodes [s] (> 0).
        solver: "csqp" (mim-solvers' constrained SQP: the scenario's inequality objectives and the inputs' bounds
            are constraints) or "box_fddp" (Crocoddyl's Box-FDDP: the objectives are exact quadratic penalties of
            weight ``penalty``, the inputs' bounds its box).
        iterations: solver iterations per control step (>= 1), warm-started from the previous solution.
        qp_iterations: CSQP's most ADMM iterations per SQP iteration (>= 1).
        recovery_nodes: CSQP: a row the measured state violates gets its bound back over this many nodes (>= 1;
            1: at the next node), linearly from the measured value; the valid set as such beyond.
        collision_margin: [m] added to the collision objectives' minimum distance at the nodes (what the plant
            loses between two solves, the inputs held and the thrusters lagging, and what a contact point's row,
            linear in the witness normal, misses on a curved surface: 3 mm keeps the pipe >= 19.9 mm against its
            20 mm in a 0.3 m/s current the MPC does not know; 2 mm let it reach 18.9 mm).
        constraint_scale: CSQP: the objectives' rows are scaled by it (a larger ADMM penalty on them; their
            units m, rad: 1000 puts them in mm, mrad against costs weighted 1e4-1e5).
        control_period: [s] the MPC solves every control_period and holds its first input in between (0: at every
            call of ``command``).
        integrator: "euler" (Crocoddyl's symplectic Euler) or "rk4" (Crocoddyl's Runge-Kutta 4).
        end_effector: weight [1/m^2] of the end effector's position error at each node.
        terminal_end_effector: the same at the last node.
        end_effector_reach: [m] the nodes' end-effector targets are kept within this distance of the measured end
            effector (moved towards it along the line to the trajectory's point; 0: the trajectory's points as they
            are): when the trajectory is out of the thrusters' reach (a current beyond them), the task's pull on the
            plan stays bounded and the constraints and the posture keep their weight.
        vehicle_position, vehicle_attitude: weights [1/m^2], [1/rad^2] of the vehicle's pose error against the
            station it was reset at (its posture; attitude = roll, pitch and yaw about the station).
        arm_posture: weight [1/rad^2] of the arm joints against their positions at reset.
        vehicle_velocity, arm_velocity: weights [s^2/m^2 or s^2/rad^2] of the velocities (damping of the plan).
        thrust: weight [1/N^2] of the thrusts (effort); arm_command: [s^2/rad^2] of the arm's velocity commands.
        penalty: Box-FDDP's weight of the squared violation of the objectives' rows (units of the rows^-2).
        knows_current: the prediction uses the plant's current (True) or still water (False: the current unknown).
        lag_compensation: invert the thrusters' first-order lag over a control period from the measured thrusts (the
            command whose response has the planned thrust as its mean over the period).
        saturation_onset: the share of the thrusters' range, asked by the estimated wrench on the vehicle (its
            minimum-norm allocation), from which the task gives way (in (0, 1)).
        saturated_task_share: the end effector's weights' share when the estimated wrench asks the thrusters' whole
            range or more (geometrically from 1 at ``saturation_onset``); 1: the task never gives way. A current
            beyond the thrusters pulls a full-weight plan onto the tilt bound, which the closed loop then overshoots
            (1.0 m/s: 0.16-0.28 rad against 0.0873); at 1e-3 the constraints come first.
        disturbance_time_constant: [s] the filter of the estimated wrench on the vehicle (the vehicle rows of the
            mismatch between the measured and the predicted acceleration over the last control period; the first one
            taken whole); 0: none.
    """

    horizon: int = 20
    node_dt: float = 0.05
    solver: str = "csqp"
    iterations: int = 1
    qp_iterations: int = 50
    recovery_nodes: int = 3
    collision_margin: float = 0.003
    constraint_scale: float = 1000.0
    control_period: float = 0.05
    integrator: str = "euler"
    end_effector: float = 1.0e4
    terminal_end_effector: float = 1.0e5
    end_effector_reach: float = 0.05
    vehicle_position: float = 10.0
    vehicle_attitude: float = 1.0e3
    arm_posture: float = 1.0
    vehicle_velocity: float = 10.0
    arm_velocity: float = 1.0
    thrust: float = 1.0e-3
    arm_command: float = 1.0
    penalty: float = 1.0e5
    knows_current: bool = False
    lag_compensation: bool = True
    disturbance_time_constant: float = 0.5
    saturation_onset: float = 0.8
    saturated_task_share: float = 1.0e-3

    def __post_init__(self) -> None:
        if not (isinstance(self.horizon, int) and self.horizon >= 1):
            raise UVMSError(f"mpc horizon must be an integer >= 1 (nodes), got {self.horizon!r}")
        for name in ("iterations", "qp_iterations", "recovery_nodes"):
            value = getattr(self, name)
            if not (isinstance(value, int) and not isinstance(value, bool) and value >= 1):
                raise UVMSError(f"mpc {name} must be an integer >= 1, got {value!r}")
        if self.solver not in SOLVERS:
            raise UVMSError(f"mpc solver must be one of {', '.join(SOLVERS)}, got {self.solver!r}")
        if self.integrator not in INTEGRATORS:
            raise UVMSError(f"mpc integrator must be one of {', '.join(INTEGRATORS)}, got {self.integrator!r}")
        for item in fields(self):
            value = getattr(self, item.name)
            if item.name in ("horizon", "solver", "iterations", "qp_iterations", "recovery_nodes", "integrator",
                             "knows_current", "lag_compensation"):
                continue
            if not (isinstance(value, (int, float)) and np.isfinite(value) and value >= 0.0):
                raise UVMSError(f"mpc {item.name} must be a finite number >= 0, got {value!r}")
        if not 0.0 < self.saturation_onset < 1.0:
            raise UVMSError(f"mpc saturation_onset must be in (0, 1), got {self.saturation_onset!r}")
        if not 0.0 < self.saturated_task_share <= 1.0:
            raise UVMSError(f"mpc saturated_task_share must be in (0, 1], got {self.saturated_task_share!r}")
        if self.node_dt <= 0.0:
            raise UVMSError(f"mpc node_dt must be > 0 s, got {self.node_dt!r}")

    @property
    def duration(self) -> float:
        """The horizon [s]."""
        return self.horizon * self.node_dt
