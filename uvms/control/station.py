"""The kinematic layer of an actuated UVMS: any solver, a vehicle pose objective, and the vehicle's velocity given.

Per control step (period dt), from the measured (q, v):

1. vehicle pose objective: nu_pose = K_pose [R^T (p_d - p); log3(R^T R_d)] towards the vehicle's station
   (:class:`uvms.control.vehicle.VehiclePoseController`), bounded by ``max_speed`` and, with saturation
   feedback, by what the thrusters can give (:meth:`ActuatedKinematics.reference`);
2. kinematic reference: the scenario's solver on the levels ``[inequalities..., task, [VehicleTask(nu_pose)]]``
   (the inequalities when the solver enforces them; the pose objective above the task for a solver whose
   ``vehicle_level`` is 0, the kinematic constraint): the end-effector task (any axes, following any
   trajectory) takes the vehicle and the arm, the pose objective brings the vehicle back to its station in the
   task's null space. Its vehicle part is the vehicle controller's setpoint;
3. coordination: the arm solved again THROUGH THE SAME SOLVER with the MEASURED vehicle velocity held fixed:
   the levels ``[[VehicleTask(nu_measured)], inequalities..., task]`` (a vehicle level at the top fixes the
   vehicle columns for every priority method), so enforced inequalities keep holding for the arm.

A solver that does not hold its levels by priority (:attr:`~uvms.solvers.base.Solver.holds_priorities` False:
CLIK stacks them and trades them off) is given the vehicle's velocity nu as fixed columns instead: built free
floating on a vehicle held still (momentum rows [I | 0], so its generalized Jacobian is the arm's columns J_a),
on the task whose feedforward is less what the vehicle gives (:class:`~uvms.tasks.task.GivenColumns`), it solves the
arm alone, qd_arm = J_a^# (K e + xdot_d - J_v nu) for CLIK, and the vehicle's part is nu. Where the vehicle's velocity
is given to the task (fixed columns, or a solver that puts the pose objective above the task), the vehicle's
reference then adds the part of the task the arm cannot give: of r = K e + xdot_d - J v, the part r_v outside
the range of the arm's columns, nu_ref = nu_pose + J_v^# r_v, translation first
(:func:`uvms.control.coordination.vehicle_rates_for_task`). An able arm leaves none; a vehicle without an arm
carries the whole task, the pose objective acting only in the task's null space.

Station keeping (:func:`station_keeping`) is one case: a held end-effector point and CLIK.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from ..dynamics.plant.actuated import ActuatedPlant
from ..dynamics.plant.command import State
from ..dynamics.thrusters.allocation import ThrustAllocator
from ..dynamics.thrusters.fin_allocation import FinAllocator
from ..errors import SolverInputError, ThrusterLayoutWarning
from ..numerics._kernels import Kernel
from ..numerics.inverses import VariableDamping
from ..robot.configuration import Configuration, configurations
from ..robot.kinematics import held_vehicle_split
from ..robot.robot import Robot
from ..solvers.base import SolverFactory
from ..solvers.clik import CLIKSolver
from ..solvers.item_rows import ItemRows
from ..solvers.stack import stacked_terms
from ..tasks.frame import FrameTask
from ..tasks.objectives import JointVelocityLimits
from ..tasks.task import GivenColumns
from ..tasks.vehicle import VehicleTask
from ..trajectory import VelocityRamps
from .coordination import CoordinatedControl, vehicle_rates_for_task
from .reference import TaskReference
from .settings import ActuatedSettings, gain_vector
from .tightening import Tightening
from .vehicle import VehiclePoseController, VehicleVelocityController

#: The vehicle's pose objective in one compiled call (:func:`uvms.numerics._kernels.vehicle.vehicle_objective_into`,
#: numba loaded at the first step).
_VEHICLE_OBJECTIVE = Kernel("vehicle", "vehicle_objective_into")


class ActuatedKinematics:
    """The kinematic reference of an actuated UVMS and the arm re-solved with a given vehicle velocity.

    Args:
        robot: a floating-base Robot.
        pose: the vehicle pose controller (the pose objective's gains and speed bound).
        reference: the end-effector task (any axes) and the trajectory it follows
            (:class:`~uvms.control.reference.TaskReference`); without a trajectory no end-effector task, the arm
            held (zero joint rates).
        solver: the solver, built per level set (twice with priorities: once per level order; once with fixed
            columns). Where the vehicle's pose objective goes relative to the task is the solver's
            :attr:`~uvms.solvers.base.Solver.vehicle_level`: 0 above it, 1 or None below. Below, the task takes
            the vehicle too and the pose objective brings the vehicle back to its station in the task's null
            space (the arm does the work while it can); above (and with fixed columns), the arm follows the task
            with the vehicle's velocity given, and the vehicle adds what the arm cannot give (a vehicle without an
            arm carries the whole task). The vehicle's added share is not bounded by saturation feedback (which
            bounds the pose objective).
        inequalities: the levels of inequality objectives the solver enforces, highest first; with any, the arm's
            speed limits (the model's) are a level above them (the solver scales the task first, never clips).
        gain: K [1/s] and damping: the DLS damping (fixed or variable) of the vehicle's added share.
        base_placement: the base frame in the vehicle joint's frame (``Robot.base_placement``; None: identity).
        tighten: move the inequalities' bounds inward by their measured tracking error for each step's solves
            (:mod:`uvms.control.tightening`).

    Raises:
        SolverInputError: a non-floating base, a bad gain, or a solver that refuses the levels.
    """

    def __init__(self, robot: Robot, pose: VehiclePoseController, reference: TaskReference, *, solver: SolverFactory,
                 inequalities: Sequence[Sequence] = (), gain: float = 1.0,
                 damping: float | VariableDamping = 0.01, base_placement: pin.SE3 | None = None,
                 tighten: bool = False) -> None:
        if robot.base_type != "floating":
            raise SolverInputError(f"an actuated UVMS needs a floating base, {robot.name} is {robot.base_type}")
        self.robot, self.pose, self.task_reference, self.task = robot, pose, reference, reference.task
        task = self.task
        self.gain = float(gain_vector(gain, "gain", 1)[0])
        self.damping = damping if isinstance(damping, VariableDamping) else float(damping)
        self.base_placement = pin.SE3.Identity() if base_placement is None else base_placement.copy()
        self._placement = (self.base_placement.rotation.copy(), self.base_placement.translation.copy())
        self._unbounded = (np.empty(6), np.empty(6))  # the clip's bounds when none are given (not read)
        self._joint_rates = np.empty(6)  # nu_pose in the vehicle joint's axes: read by the step's solves alone
        self._vehicle_reference, self._vehicle_measured = VehicleTask.at_rest(robot), VehicleTask.at_rest(robot)
        levels = [list(level) for level in inequalities]
        tightened = [objective for level in levels for objective in level if objective.collision]
        self.tightening = Tightening(tightened) if tighten and tightened and reference.moving else None
        if levels:  # the arm's speed limits held by the hierarchy (the task scaled first), not clipped after it
            levels.insert(0, [JointVelocityLimits(robot, name="arm_speed_limits")])
        nb, vehicle_level = robot.n_vehicle, solver.cls.vehicle_level
        self._given: GivenColumns | None = None  # the task with the vehicle's columns given (fixed columns)
        self._momentum = None  # the configuration's momentum rows: a vehicle held still with fixed columns
        if solver.cls.holds_priorities:
            reference_levels = [task]
            reference_levels.insert(len(reference_levels) if vehicle_level is None else vehicle_level,
                                    [self._vehicle_reference])
            self.reference_solver = solver([*levels, *reference_levels])
            self.arm_solver = solver([[self._vehicle_measured], *levels, task])
        else:  # the vehicle's velocity as fixed columns (module docstring): one solver for both
            self._given = GivenColumns(task, nb)
            self._momentum = lambda q: held_vehicle_split(nb, robot.n_arm)  # noqa: ARG005 - constant rows
            self.reference_solver = self.arm_solver = solver([*levels, self._given], free_floating=True)
        #: the vehicle's velocity is given to the task (fixed columns, a pose objective above it): the vehicle then
        #: adds the part of the task the arm cannot give (all of it without an arm)
        self.vehicle_given = self._given is not None or vehicle_level == 0
        self._configuration: Configuration | None = None
        #: world_M_base [m, rad] where the vehicle is held, or None: its base frame's pose where the run starts
        self.station: pin.SE3 | None = None
        self.vehicle_target: pin.SE3 | None = None  # the station of the run (:meth:`reset`)

    def reset(self, state: State, t: float = 0.0) -> None:
        """A run from ``state``: the vehicle held at :attr:`station`, else at its base frame's pose there; the
        trajectory's sample the task points at and the tightening's margins forgotten."""
        self.vehicle_target = self.base_pose(state.q) if self.station is None else self.station.copy()
        self.task_reference.forget()
        if self._configuration is not None:
            self._rows.clear()
        if self.tightening is not None:
            self.tightening.restore()
            self.tightening.reset()

    def _at(self, t: float, q: np.ndarray) -> Configuration:
        """The configuration at q (one kept, updated), the task pointed at the trajectory's sample of t."""
        if self._configuration is None:
            self._configuration = Configuration(self.robot, q, check=False, momentum=self._momentum)
            # the items' rows at the step's q: the reference's solve evaluates them, the coordination's reads them
            self._rows = ItemRows()
        else:
            self._configuration.update(q, check=False)
        if self.task_reference.follow(t):
            self._rows.clear()
        return self._configuration

    def base_pose(self, q: np.ndarray) -> pin.SE3:
        """world_M_base of the vehicle's base frame (its link frame, not only the joint)."""
        return self.robot.base_pose(q) * self.base_placement

    def vehicle_objective(self, q: np.ndarray, bounds: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
        """nu_pose (6,) [m/s, rad/s] in the base frame, within ``bounds`` (lower, upper) (6,) when given."""
        joint = self.robot.base_pose(q)  # the vehicle joint's placement
        return self._vehicle_objective(joint.rotation, joint.translation, bounds)[0]

    def _vehicle_objective(self, joint_rotation: np.ndarray, joint_translation: np.ndarray,
                           bounds: tuple[np.ndarray, np.ndarray] | None) -> tuple[np.ndarray, np.ndarray]:
        """(nu_pose (6,) of the base frame of the vehicle joint placed at (R (3, 3), p (3,)), within ``bounds`` when
        given; that twist in the vehicle joint's axes (6,), this object's buffer until the next call): the pose law
        (:func:`~uvms.control.vehicle.pose_velocity_reference`), ``np.clip`` and ``base_placement.act`` in one
        compiled call (:func:`uvms.numerics._kernels.vehicle.vehicle_objective_into`: their numbers)."""
        nu, joint_rates = np.empty(6), self._joint_rates  # nu new: a row keeps nu_pose
        pose, target = self.pose, self.vehicle_target
        lower, upper = self._unbounded if bounds is None else bounds
        (_VEHICLE_OBJECTIVE.function or _VEHICLE_OBJECTIVE.load())(
            joint_rotation, joint_translation, *self._placement, target.rotation, target.translation, pose.gains,
            pose.gains if pose.max_speed is None else pose.max_speed, pose.max_speed is not None, lower, upper,
            bounds is not None, nu, joint_rates)
        return nu, joint_rates

    def _solve(self, configuration: Configuration, vehicle: np.ndarray, reference: bool,
               diagnostics: bool) -> tuple[np.ndarray, object]:
        """(v (nv,), the SolverResult or None) with the vehicle's velocity (joint axes) given: above the task
        (reference) or on top; without ``diagnostics`` the solver gives v alone (the same numbers)."""
        nb = self.robot.n_vehicle
        if not self.task_reference.moving:
            return np.concatenate([vehicle, np.zeros(self.robot.n_arm)]), None
        if self._given is not None:  # fixed columns: the arm solved with the vehicle's velocity given
            self._given.velocity[:] = vehicle
            solver = self.reference_solver
            result = solver.velocity(configuration) if diagnostics else None
            v = np.concatenate([vehicle, (solver.stage_velocity(configuration) if result is None else result.v)[nb:]])
        else:
            level = self._vehicle_reference if reference else self._vehicle_measured
            level.velocity_values[:] = vehicle
            solver = self.reference_solver if reference else self.arm_solver
            # both solves share the objectives and the task (not the vehicle levels): evaluated once per step
            solve = solver.velocity if diagnostics else solver.stage_velocity
            shares = getattr(solver, "shares_rows", False)
            answer = solve(configuration, shared=self._rows) if shares else solve(configuration)
            result, v = (answer, answer.v) if diagnostics else (None, answer)
        if reference and self.vehicle_given:
            v = v.copy()
            v[:nb] += self._vehicle_share(configuration, v)
        return v, result

    def _vehicle_share(self, configuration: Configuration, v: np.ndarray) -> np.ndarray:
        """What the vehicle adds (n_vehicle,) (joint axes) for the part of the task the arm cannot give: of the
        residual r = K e + xdot_d - J v, what lies outside the arm's range
        (:func:`~uvms.control.coordination.vehicle_rates_for_task`)."""
        jacobian, error, feedforward = stacked_terms(configuration, [self.task])
        residual = self.gain * error + feedforward - jacobian @ v
        return vehicle_rates_for_task(jacobian, residual, self.robot.n_vehicle, damping=self.damping)

    def reference(self, t: float, q: np.ndarray,
                  bounds: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[np.ndarray, dict]:
        """v_ref (nv,) (vehicle part in the vehicle joint's axes) and {"nu_pose": (6,) base frame, "solver": the
        SolverResult or None} at (t, q); ``bounds``: the vehicle velocities the thrusters can give (base frame)."""
        v, result, nu_pose = self._reference(t, q, bounds, diagnostics=True)
        return v, {"nu_pose": nu_pose, "solver": result}

    def coordinated(self, t: float, q: np.ndarray, vehicle_velocity: np.ndarray,
                    bounds: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(v_ref (nv,), the arm rates (n_arm,)): :meth:`reference` at (t, q), then :meth:`arm_rates` with the vehicle
        velocity (n_vehicle,) (joint axes) held, at the configuration the reference moved to q (a coordinated step's
        two solves; the same numbers as the two calls)."""
        v, _, _ = self._reference(t, q, bounds, diagnostics=False)
        arm, _ = self._solve(self._configuration, vehicle_velocity, reference=False, diagnostics=False)
        return v, arm[self.robot.n_vehicle:]

    def _reference(self, t: float, q: np.ndarray, bounds: tuple[np.ndarray, np.ndarray] | None,
                   diagnostics: bool) -> tuple[np.ndarray, object, np.ndarray]:
        """(v_ref (nv,), the SolverResult (None without ``diagnostics``: v alone solved), nu_pose (6,))."""
        self.robot.check_configuration(q)  # the step's q, checked once (the configuration takes it unchecked)
        configuration = self._at(t, q)
        # the base frame's pose from the step's kinematics (the vehicle joint's placement: base_pose's numbers); the
        # vehicle's velocity in the joint's axes
        _, translation, rotation = configuration.joint_arrays(1)
        nu_pose, vehicle = self._vehicle_objective(rotation, translation, bounds)
        if self.tightening is not None:  # the bounds moved for this step's solves, until :meth:`asked`
            self.tightening.measure(t, configuration)
        self._rows.clear()  # this step's rows, with this step's bounds
        v, result = self._solve(configuration, vehicle, reference=True, diagnostics=diagnostics)
        if self.tightening is not None:  # what the reference, which keeps the objectives, predicts for the next step
            self.tightening.predict(t, v)
        return v, result, nu_pose

    def step_done(self) -> None:
        """The step's solves are done: the objectives' nominal bounds back (recorders read them). Rows evaluated
        with nominal bounds are kept for :meth:`objective_rows` (the next step's reference clears them)."""
        if self.tightening is not None:
            if self._configuration is not None:
                self._rows.clear()
            self.tightening.restore()

    def objective_rows(self, q: np.ndarray) -> ItemRows | None:
        """The objectives' rows this step's solves evaluated at ``q`` (nq,) with their nominal bounds, for a recorder
        to read instead of evaluating them again (an objective not evaluated yet is evaluated there at its first
        read); None when there are none: no shared solve at q (a solver that does not share rows, the arm held),
        or the bounds were tightened."""
        if self._configuration is None or self.tightening is not None:  # no step yet (its rows made there)
            return None
        return self._rows.evaluated_at(q)

    def arm_rates(self, t: float, q: np.ndarray, vehicle_velocity: np.ndarray) -> np.ndarray:
        """The arm rates (n_arm,) of the same solver with the vehicle velocity (n_vehicle,) (joint axes) held."""
        v, _ = self._solve(self._at(t, q), vehicle_velocity, reference=False, diagnostics=False)
        return v[self.robot.n_vehicle:]

    def error_series(self, t: np.ndarray, q: np.ndarray) -> dict[str, np.ndarray]:
        """The run's error series, derived after the loop from its stored rows t (N,) [s] and q (N, nq): the vehicle's
        position [m] and attitude [rad] errors from its station (the base frame's), "vehicle_position_error" and
        "vehicle_attitude_error" (N,); the end effector's position "ee_position" (N, 3) [m] world and, following a
        trajectory, its distance [m] from the trajectory's point, "ee_point_error" (N,).

        Each row's numbers are those of the kinematics at its q, from a configuration of its own moved along the rows
        (the solver's is left as it is): the station's errors in one compiled call (Pinocchio's and numpy's numbers;
        the norms as numpy's norm of a vector computes them, sqrt of x.dot(x)).
        """
        count, frame_id = len(q), self.task.frame_id
        position, attitude, ee = np.empty(count), np.empty(count), np.empty((count, 3))
        kernel = _STATION_ERRORS.function or _STATION_ERRORS.load()
        target, placement = self.vehicle_target, self.base_placement
        station = (placement.rotation, placement.translation, target.rotation, target.translation)
        for row, state in enumerate(configurations(self.robot, q, check=False)):  # q: the run's, checked at its steps
            _, translation, rotation = state.joint_arrays(1)  # the vehicle joint's placement
            position[row], attitude[row] = kernel(rotation, translation, *station)
            ee[row] = state.pose(frame_id).translation
        series = {"vehicle_position_error": position, "vehicle_attitude_error": attitude, "ee_position": ee}
        if self.task_reference.moving:
            samples, point = self.task_reference.samples, np.empty(count)
            for row, time in enumerate(np.asarray(t, dtype=float).tolist()):
                miss = samples.target(time)[0] - ee[row]  # the target's translation (no sample built)
                point[row] = math.sqrt(miss.dot(miss))
            series["ee_point_error"] = point
        return series


def station_keeping(actuated: ActuatedPlant, q0: np.ndarray, dt: float,
                    settings: ActuatedSettings = ActuatedSettings(), *, ee_target: np.ndarray | None = None,
                    hold_arm: bool = False, ee_gain: float = 1.0, arm_damping: float = 0.01,
                    frame: str | None = None) -> CoordinatedControl:
    """The controller of ``actuated`` holding the vehicle at its pose of q0 (its station: the run may start elsewhere)
    and the end-effector point at ``ee_target`` (default: where it is at q0; ``hold_arm``: no end-effector task, the
    arm held):
    :func:`actuated_control` with a held point and CLIK (the settings' defaults:
    :class:`~uvms.control.settings.ActuatedSettings`).

    Args:
        actuated, dt, settings: as in :func:`actuated_control`.
        q0: (nq,) the station: the vehicle's pose held, the end-effector point's default.
        ee_gain: K_ee [1/s] of the point task; arm_damping: DLS damping of the arm inverse (CLIK's).
        frame: the end-effector frame held (default: the model's first end effector).

    Returns:
        A CoordinatedControl whose ``kinematic`` is the ActuatedKinematics of the held point.
    """
    robot = actuated.robot
    frame = frame or robot.ee_frames[0]
    start = Configuration(robot, q0).pose(robot.frame_id(frame)).copy()
    point = start.translation if ee_target is None else np.asarray(ee_target, dtype=float).reshape(3)
    hold = None if hold_arm else VelocityRamps.trapezoid(point, np.zeros(3), 1.0, 0.5, rotation=start.rotation)
    solver = SolverFactory(CLIKSolver, robot, {"gain": ee_gain, "damping": arm_damping})
    reference = TaskReference(FrameTask(robot, frame, axes=("x", "y", "z")), hold)
    controller = actuated_control(actuated, dt, reference, solver, settings)
    controller.kinematic.station = controller.kinematic.base_pose(q0)
    return controller


def actuated_control(actuated: ActuatedPlant, dt: float, reference: TaskReference, solver: SolverFactory,
                     settings: ActuatedSettings = ActuatedSettings(), *,
                     inequalities: Sequence[Sequence] = ()) -> CoordinatedControl:
    """The whole chain on ``actuated``: the vehicle held at its station, its pose where the run starts
    (:meth:`CoordinatedControl.reset <uvms.control.coordination.CoordinatedControl.reset>`), the reference's task
    following its trajectory.

    Args:
        actuated: the simulated plant with its thrusters (and fins); its robot and hydrodynamics are the controller's
            model, without the current unless ``settings.knows_current``; its allocation matrix and thrust bounds the
            allocation's (:class:`uvms.dynamics.thrusters.allocation.ThrustAllocator`; with fins, allocated with the
            thrusters at each step's velocity: :class:`uvms.dynamics.thrusters.fin_allocation.FinAllocator`).
        dt: control period [s] (the simulation step).
        reference, inequalities: as in :class:`ActuatedKinematics`.
        solver: as in :class:`ActuatedKinematics`; its ``gain`` K [1/s] and ``damping`` (0 when it has none) are
            those of the vehicle's added share.
        settings: the loops, the allocation's priorities and the coordination
            (:class:`~uvms.control.settings.ActuatedSettings`): kp, ki given are used as they are, else derived from
            the bandwidth, the damping ratio and the vehicle's inertia M_ii at the station, kp = 2 zeta omega M_ii,
            ki = omega^2 M_ii (:func:`uvms.control.vehicle.velocity_gains`).
    """
    plant, robot = actuated.plant, actuated.robot
    model = plant.copy(current=None if settings.knows_current else np.zeros(3))
    priorities = settings.priorities or None
    allocator = FinAllocator(actuated.matrix, actuated.lower, actuated.upper, actuated.fins, priorities=priorities) \
        if actuated.fins else ThrustAllocator(actuated.matrix, actuated.lower, actuated.upper, priorities=priorities)
    note = allocator.reach_note(actuated.thrusters.names)
    if note:  # a vehicle that cannot hold every degree of freedom is told so, once
        warnings.warn(note, ThrusterLayoutWarning, stacklevel=2)
    velocity = VehicleVelocityController(model, allocator, settings)
    pose = VehiclePoseController(velocity, settings.pose_gains, settings.max_speed)
    kinematic = ActuatedKinematics(robot, pose, reference, solver=solver, inequalities=inequalities,
                                   gain=solver.options.get("gain", 1.0), damping=solver.options.get("damping", 0.0),
                                   base_placement=model.robot.base_placement, tighten=settings.tightening)
    return CoordinatedControl(robot, velocity, kinematic, dt,
                              coordination=settings.coordination and reference.moving,
                              saturation_feedback=settings.saturation_feedback,
                              acceleration_feedforward=settings.acceleration_feedforward,
                              servo_compensation=settings.servo_compensation)


#: The compiled station errors of :meth:`ActuatedKinematics.error_series` (numba loaded at its first call).
_STATION_ERRORS = Kernel("vehicle", "station_errors")
