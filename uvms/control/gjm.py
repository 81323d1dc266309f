"""Inverse kinematic control of a free-floating UVMS with the generalized Jacobian (amundsen2018, sec. II-III).

The vehicle is passive: only the joints are commanded, and the end effector is
controlled in inertial (world) axes through the generalized Jacobian matrix
(GJM), which accounts for the vehicle's reaction. With the task rows ``rows``
(e.g. the 3 linear ones, the sub-matrix of sec. III) and the end-effector
reference p_d(t), v_d(t)::

    nu_c = [v_d + K (p_d - p); omega_d]                  (eq. 8, position feedback only)
    w    = GJM_r^T (GJM_r GJM_r^T + lambda^2 I)^-1 nu_c  (eq. 4-5, DLS)
    lambda^2 = (1 - (sigma_min / eps)^2) lambda_max^2 when sigma_min < eps, else 0   (eq. 6)

K = 0 is the paper's open loop (the joints integrate the commanded velocities;
the end-effector position is only measured, never fed back); K = 3 I its closed
loop (CLIK, eq. 7). The GJM is evaluated at the measured joint angles and
vehicle orientation (encoders and IMU), as in the paper.

Which GJM (``gjm``):

* ``"rigid"`` — the classic one, from the rigid-body momentum (``Robot.generalized_jacobian``);
* ``"added_mass"`` — from the momentum of the links *and the water they carry*
  (link inertias augmented with their added mass,
  :func:`uvms.dynamics.plant.added_mass.generalized_jacobian_added_mass`): exact in an inviscid fluid at rest, where
  that augmented momentum is conserved;
* ``"fixed_base"`` — the arm columns J_m of the ordinary Jacobian, as if the vehicle
  were held still (the traditional scheme the paper contrasts with; for comparisons).

By default this is CLIK with ``free_floating=True`` (:class:`uvms.solvers.CLIKSolver`, built once): a ``FrameTask``
(log orientation error, no gain on its angular rows) gives nu_c; a
:class:`uvms.robot.configuration.Configuration` whose momentum rows are the chosen ones (rigid centroidal
map, added-mass-augmented mass matrix, or a vehicle held still) gives the GJM by the one formula of
:mod:`uvms.robot.kinematics`; the inverse is the solvers' damped weighted inverse (fixed damping or
``VariableDamping``). GJM^# applied to another twist x (the servo feedforward below) is the same CLIK in open
loop (K = 0) with x as its feedforward.

Any solver. ``solver`` (a :class:`uvms.solvers.base.SolverFactory`: any class of :data:`uvms.solvers.SOLVERS`
with its options) is built with ``free_floating=True`` on the levels ``[*levels, task]``: inequality objectives
above the task (``levels``, e.g. joint limits, for a solver that enforces them,
:attr:`~uvms.solvers.base.Solver.enforces_inequalities`: set_based, hqp), then the task.
Every solver solves the arm only; the vehicle, passive, follows momentum conservation through the chosen GJM.
A solver that needs a level the passive vehicle cannot give (the kinematic constraint's first level, a
vehicle task) is refused. With levels above the task the solution is no longer linear in nu_c: the
feedforward's command term below is then the open-loop solver fed d nu_c/dt minus the same fed 0 (what the
objectives ask of themselves at q), the task's share of it; with the task alone (fed 0 gives 0) it is
GJM^# d nu_c/dt as before.

Joint servos. The plant's joints follow their commanded velocity through a
first-order servo of time constant tau (amundsen2018: 100 ms). Sent as is, w is
tracked with a lag, which alone moves the end effector off its reference; with
``motor_feedforward = tau`` the controller sends u = w + tau dw/dt, the inverse of
the servo, so that the joint rates equal w whenever they did at the start.
dw/dt is taken along the measured motion: dw/dt = (d GJM^#/dt) nu_c + GJM^# d nu_c/dt,
the first term by a forward difference along q' = v, the second from the
reference acceleration.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..dynamics.hydro.hydrodynamics import HydroParameters, hydrodynamics_of
from ..dynamics.plant.added_mass import augmented_mass_matrix, resolve_links
from ..dynamics.plant.command import Command, State
from ..errors import GJMControlError, UVMSError
from ..numerics.inverses import VariableDamping, weights_factor
from ..robot.configuration import Configuration, MomentumRows
from ..robot.kinematics import AXIS_NAMES, axis_rows, held_vehicle_split, mass_matrix_split
from ..robot.robot import Robot
from ..solvers.base import SolverFactory
from ..solvers.clik import CLIKSolver
from ..solvers.result import SolverResult
from ..tasks.frame import FrameTask
from ..trajectory.cartesian import PoseSample
from ..trajectory.ramps import VelocityRamps

__all__ = ["GJM_KINDS", "GJMControlError", "GJMController", "GJMSample", "VelocityRamps"]

#: The generalized Jacobians the controller can invert.
GJM_KINDS = ("rigid", "added_mass", "fixed_base")


@dataclass(frozen=True)
class GJMSample:
    """What the controller computes at one (q, t).

    Attributes:
        rates: w (n_arm,) joint velocities [rad/s] (before the servo feedforward).
        command: nu_c (k,) the task velocity inverted (eq. 8) [m/s, rad/s].
        position_error: p_d - p (3,) [m] world (zeros when the task has no position row).
        sigma_min: smallest singular value of the task rows of the GJM.
        damping: lambda used (eq. 6).
    """

    rates: np.ndarray
    command: np.ndarray
    position_error: np.ndarray
    sigma_min: float
    damping: float


@dataclass(frozen=True)
class _Solution:
    """One CLIK solve at (q, t): the state, the reference sample and the solver's result."""

    state: Configuration
    reference: PoseSample
    result: SolverResult


class GJMController:
    """Joint-velocity commands that move a frame along a reference with the vehicle passive.

    Args:
        robot: a floating- or planar-base Robot.
        reference: t -> PoseSample (pose, twist (6,), acceleration (6,)), e.g.
            :class:`VelocityRamps` or a ``uvms.trajectory`` pose trajectory.
        frame: controlled frame (default: the first end effector).
        axes: task axes, any of x y z roll pitch yaw (default x, y, z: 3-DOF linear control,
            the sub-matrix of amundsen2018 sec. III). Position axes get feedback, angular
            ones only the reference's angular velocity (eq. 8).
        gain: K [1/s]: scalar, (3,) diagonal or (3, 3), on the position error; 0 = open loop.
        damping: fixed lambda >= 0 or a :class:`uvms.solvers.VariableDamping` (eq. 6).
        weights: joint weights W (n_arm,) or (n_arm, n_arm) (weighted DLS); None: W = I as in the paper.
        gjm: "rigid", "added_mass" or "fixed_base" (see the module docstring).
        hydro: parameters of the added-mass GJM (None: the model's own).
        motor_feedforward: tau [s] of the joint servos to invert (u = w + tau dw/dt); 0: send w.
        difference_step: time step [s] of the forward difference of dGJM^#/dt.
        solver: the solver and its options (e.g. ``dt`` [s] for hqp, ``eta`` for set_based), built here with
            ``free_floating=True``, the weights, damping and gain above (None: CLIK).
        levels: the levels above the task, highest first (each an objective or a list of them: inequality
            objectives, speed limits), for a solver that enforces them.

    Raises:
        GJMControlError: a fixed base, unknown axes or GJM kind, bad gain or tau; levels for a solver that does
            not enforce inequalities; a solver that needs a fixed number of levels (its first the vehicle's);
            weights, damping or an option the solver does not take.
        SolverInputError: weights not (n_arm,) positive nor (n_arm, n_arm) symmetric positive definite, a
            bad damping, or a bad option or level of the solver.
        UVMSError: the model has no hydrodynamic parameters and ``gjm = "added_mass"``.
    """

    def __init__(
        self,
        robot: Robot,
        reference,
        *,
        frame: str | None = None,
        axes: Sequence[str] = ("x", "y", "z"),
        gain: float | np.ndarray = 0.0,
        damping: float | VariableDamping = 0.0,
        weights: np.ndarray | None = None,
        gjm: str = "rigid",
        hydro: HydroParameters | None = None,
        motor_feedforward: float = 0.0,
        difference_step: float = 1e-6,
        solver: SolverFactory | None = None,
        levels: Sequence = (),
    ) -> None:
        if robot.base_type == "fixed":
            raise GJMControlError(f"{robot.name} has a fixed base: GJM control "
                                  "needs a free-floating (or planar) vehicle")
        if gjm not in GJM_KINDS:
            raise GJMControlError(f"unknown gjm {gjm!r}; valid: {', '.join(GJM_KINDS)}")
        try:
            self.rows = axis_rows(axes)
        except UVMSError as exc:
            raise GJMControlError(str(exc)) from None
        if not self.rows:
            raise GJMControlError(f"axes must name at least one of {', '.join(AXIS_NAMES)}")
        self.robot, self.reference, self.gjm = robot, reference, gjm
        self.frame = frame or robot.ee_frames[0]
        self.frame_id = robot.frame_id(self.frame)
        self.axes = tuple(axes)
        self.position_rows = [i for i, row in enumerate(self.rows) if row < 3]  # indices into the task rows
        self.gain = _gain_matrix(gain)
        self.task = FrameTask(robot, self.frame, axes=self.axes, orientation="log")  # the core's task
        self.task_gain = _task_gain(self.gain, self.rows)  # K on the task rows: position feedback only (eq. 8)
        self.damping = damping
        self.weights = None if weights is None else np.asarray(weights, dtype=float)
        if self.weights is not None:
            weights_factor(self.weights, robot.n_arm)  # raises SolverInputError with what is valid
        tau = float(motor_feedforward)
        if not (np.isfinite(tau) and tau >= 0):
            raise GJMControlError(f"motor_feedforward must be a time constant >= 0 s, got {motor_feedforward!r}")
        self.motor_feedforward = tau
        step = float(difference_step)
        if not (np.isfinite(step) and step > 0):
            raise GJMControlError(f"difference_step must be > 0 s, got {difference_step!r}")
        self.difference_step = step
        self.model = robot.model
        self._mass_data = robot.model.createData()
        self.nb = robot.n_vehicle
        self.links = []
        self.hydro = hydro
        if gjm == "added_mass":
            self.hydro = hydrodynamics_of(robot) if hydro is None else hydro
            self.links = resolve_links(self.model, self.hydro)
        self._momentum = self._momentum_rows()
        self.levels = list(levels)
        solver = SolverFactory(CLIKSolver, robot) if solver is None else solver
        options = _solver_options(solver, self.levels, self.weights, damping)
        # the law, built once: the solver on the generalized Jacobian (closed loop with K on the position rows),
        # and the same in open loop, whose feedforward is any twist x: GJM^# x (the servo feedforward)
        self.solver = solver([*self.levels, self.task], gain=self.task_gain, **options)
        self._open_task = FrameTask(robot, self.frame, axes=self.axes, orientation="log")
        self._open = solver([*self.levels, self._open_task], gain=0.0, **options)
        # the states a command works in, at the measured q and a difference step ahead: built once, then moved
        self._kept: list[Configuration | None] = [None, None]

    # ------------------------------------------------------------- Jacobians
    def _momentum_rows(self) -> MomentumRows | None:
        """The momentum rows the chosen GJM conserves (None: the rigid centroidal map)."""
        nb, n_arm = self.nb, self.robot.n_arm
        if self.gjm == "fixed_base":
            return lambda q: held_vehicle_split(nb, n_arm)
        if self.gjm == "added_mass":
            return lambda q: mass_matrix_split(augmented_mass_matrix(self.model, self._mass_data, self.links, q), nb)
        return None

    def state(self, q: np.ndarray, check: bool = False) -> Configuration:
        """The controller's state at q: its own data, the chosen momentum rows."""
        return Configuration(self.robot, q, check=check, momentum=self._momentum)

    def _moved(self, slot: int, q: np.ndarray) -> Configuration:
        """The kept state ``slot`` (0: at the measured q, 1: a difference step ahead) moved to q (nq,), unchecked
        (the loop's q); each is built at its first use (a ``pin.Data`` costs tens of microseconds), then updated."""
        state = self._kept[slot]
        if state is None:
            state = self._kept[slot] = self.state(q)
        else:
            state.update(q, check=False)
        return state

    def generalized_jacobian(self, q: np.ndarray) -> np.ndarray:
        """The GJM (6, n_arm) this controller inverts (all six rows, world-aligned)."""
        state = self.state(q, check=True)
        return state.generalized(state.jacobian(self.frame_id))

    # ------------------------------------------------------------- control
    def _solve(self, state: Configuration, t: float) -> _Solution:
        """The CLIK of the core at (state, t): nu_c from the task, the damped weighted inverse of its GJM rows."""
        reference = self.reference(t)
        self.task.set_target(reference.pose)
        self.task.set_target_velocity(reference.twist)
        return _Solution(state, reference, self.solver.velocity(state))

    def _inverse_times(self, state: Configuration, twist: np.ndarray, pose) -> np.ndarray:
        """GJM^# x (n_arm,) at ``state`` of the task rows of a twist x (6,): the open-loop CLIK fed x."""
        self._open_task.set_target(pose)
        self._open_task.set_target_velocity(twist)
        return self._open.velocity(state).v[self.nb:]

    def _position_error(self, solution: _Solution) -> np.ndarray:
        if not self.position_rows:
            return np.zeros(3)
        return solution.reference.pose.translation - solution.state.pose(self.frame_id).translation

    def sample(self, q: np.ndarray, t: float) -> GJMSample:
        """The joint rates w at (q, t) and the quantities behind them.

        Raises:
            ConfigurationError: q of the wrong size or not finite.
        """
        return self._sample(self.state(q, check=True), t)

    def _sample(self, state: Configuration, t: float) -> GJMSample:
        solution = self._solve(state, t)
        result = solution.result
        return GJMSample(result.v[self.nb:], result.command, self._position_error(solution), result.sigma_min,
                         result.damping)

    def tracking(self, t: float, q: np.ndarray, v: np.ndarray) -> dict:
        """The tracking series of a run's row at (t, q, v): pose and velocity of the frame and of the reference,
        the joint rates w and the inverse's sigma_min and damping (what :func:`uvms.sim.simulate` records of a plant
        run)."""
        state = self._moved(0, q)
        sample = self._sample(state, t)
        reference = self.reference(t)
        return {"ee_position": state.pose(self.frame_id).translation.copy(),
                "desired_position": reference.pose.translation.copy(),
                "ee_velocity": state.jacobian(self.frame_id)[:3] @ v, "desired_velocity": reference.twist[:3].copy(),
                "rates": sample.rates, "sigma_min": sample.sigma_min, "damping": sample.damping}

    def reset(self, state: State, t: float = 0.0) -> None:
        """Nothing to reset: the law depends on (q, v, t) only."""

    def command(self, state: State, t: float) -> Command:
        """``Command(arm=u (n_arm,))`` at the measured (q, v) and t: w, plus tau dw/dt with the servo feedforward
        (:class:`uvms.control.base.Controller`)."""
        return Command(arm=self.joint_command(t, state.q, state.v))

    def joint_command(self, t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """The joint-velocity command u (n_arm,) at (t, q, v): w, plus tau dw/dt with the servo feedforward."""
        solution = self._solve(self._moved(0, q), t)
        rates = solution.result.v[self.nb:]
        if self.motor_feedforward == 0.0:
            return rates
        h = self.difference_step
        reference = solution.reference
        command = np.zeros(6)
        command[self.rows] = solution.result.command  # nu_c (k,) as a twist (6,) on the task rows
        ahead = self._inverse_times(self._moved(1, pin.integrate(self.model, q, v * h)), command, reference.pose)
        jacobian = solution.state.jacobian(self.frame_id)
        command_rate = reference.acceleration.copy()  # d nu_c / dt = a_d + K (v_d - p')
        command_rate[:3] += self.gain @ (reference.twist[:3] - jacobian[:3] @ v)
        command_term = self._inverse_times(solution.state, command_rate, reference.pose)
        if self.levels:  # the objectives' own share, fed no task velocity (module docstring)
            command_term = command_term - self._inverse_times(solution.state, np.zeros(6), reference.pose)
        rate_of_rates = (ahead - rates) / h + command_term
        return rates + self.motor_feedforward * rate_of_rates


def _gain_matrix(gain) -> np.ndarray:
    """K (3, 3) from a scalar, a diagonal (3,) or a matrix (3, 3); finite and >= 0 (positive semi-definite)."""
    array = np.asarray(gain, dtype=float)
    if array.ndim == 0:
        array = float(array) * np.eye(3)
    elif array.shape == (3,):
        array = np.diag(array)
    if array.shape != (3, 3) or not np.all(np.isfinite(array)):
        raise GJMControlError(f"gain K must be a number, 3 numbers or a 3x3 matrix [1/s], got {gain!r}")
    if np.min(np.linalg.eigvalsh(0.5 * (array + array.T))) < 0:
        raise GJMControlError(f"gain K must be positive semi-definite (0 = open loop), got {gain!r}")
    return array


def _task_gain(gain: np.ndarray, rows: list[int]) -> np.ndarray:
    """The CLIK gain (k, k) on the task rows: the position block of K, zero on the angular rows (eq. 8)."""
    task_gain = np.zeros((len(rows), len(rows)))
    for i, row in enumerate(rows):
        for j, column in enumerate(rows):
            if row < 3 and column < 3:
                task_gain[i, j] = gain[row, column]
    return task_gain


def _solver_options(solver: SolverFactory, levels: list, weights: np.ndarray | None,
                    damping: float | VariableDamping) -> dict:
    """The keywords the controller adds to ``solver``'s (free floating, the weights and damping when given),
    every one checked against what its class takes.

    Raises:
        GJMControlError: not a SolverFactory, levels for a solver that does not enforce inequalities, a solver
            of a fixed number of levels, or a keyword it does not take.
    """
    if not isinstance(solver, SolverFactory):
        raise GJMControlError(f"solver must be a uvms.solvers.base.SolverFactory (a class of uvms.solvers.SOLVERS "
                              f"and its options), got {solver!r}")
    cls = solver.cls
    if levels and not cls.enforces_inequalities:
        raise GJMControlError(f"levels above the task need a solver that enforces inequalities (set_based, hqp); "
                              f"{cls.__name__} would not use them")
    if cls.level_count is not None:
        raise GJMControlError(f"{cls.__name__} needs {cls.level_count} levels, the first of them a constraint "
                              f"such as a vehicle task, which a passive vehicle cannot follow (it has no actuators): "
                              f"use clik, task_priority, set_based or hqp, or a plant with thrusters")
    added: dict = {"free_floating": True}
    if weights is not None:
        added["weights"] = weights
    if not (isinstance(damping, (int, float)) and damping == 0.0):
        added["damping"] = damping
    refused = [key for key in {**solver.options, **added} if key not in cls.options()]
    if refused:
        raise GJMControlError(f"{cls.__name__} takes no {refused[0]!r} (it takes {', '.join(cls.options())})")
    return added
