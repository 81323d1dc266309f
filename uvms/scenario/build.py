"""Building a run from a checked scenario: model, task, initial configuration, trajectory, controller, plant."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..control.gjm import GJMController
from ..control.sequence import Phase, PhasePlan, SequenceController
from ..control.tracking import TrackingController
from ..dynamics.plant.plant import Plant
from ..errors import NameNotFound, ScenarioError, SolverInputError, UVMSError
from ..numerics.integrate import stage_times, step_count
from ..robot.configuration import Configuration
from ..robot.robot import Robot
from ..solvers import SOLVERS, Solver, VariableDamping, initial_configuration
from ..solvers.base import SolverFactory
from ..tasks import FrameTask, MidRangePotential, VehicleTask
from ..trajectory import PathTrajectory, RecentSamples, SE3Trajectory, TrajectoryTable
from .actuated import Actuation, actuated_plant, make_actuation
from .excitation import scenario_excitation
from .inequalities import ScenarioInequalities, build_inequalities
from .plant import make_plant
from .record import scenario_model
from .spec import NUMBER, ScenarioSpec, SolverSpec
from .spec.keys import thaw
from .trajectories import make_trajectory

#: [solver] keys that set a constructor keyword of another name (the variable damping's two set ``damping``).
RENAMED_KEYWORDS = {"damping_epsilon": "damping", "damping_max": "damping"}
#: [solver] keys -> the solver constructor's keyword they set: every key of the section (a new option is its
#: SolverSpec key and the constructor's keyword of the same name), but solver.method and solver.joint_limit_weights,
#: which the initial configuration also reads, and which are not options of a solver.
SOLVER_KEYWORDS = {name: RENAMED_KEYWORDS.get(name, name) for name in SolverSpec.keys()
                   if name not in ("method", "joint_limit_weights")}

@dataclass
class Setup:
    """Everything a run needs, built from a validated scenario."""

    robot: Robot
    task: FrameTask
    trajectory: PathTrajectory | SE3Trajectory
    q0: np.ndarray
    controller: Any
    duration: float
    initial_residual: float
    plan: PhasePlan | None = None  # sequence scenarios only
    plant: Plant | None = None  # [plant] type rigid or hydrodynamic: the controller is a GJMController
    control_dt: float = 0.0  # [s] sampling period of that controller (0: continuous)
    inequalities: ScenarioInequalities | None = None  # [[inequalities]]: enforced (set_based, hqp) or monitored
    actuation: Actuation | None = None  # plant.thrusters: the thrusters and the chain's (or the MPC's) controller
    samples: RecentSamples | None = None  # the trajectory as the kinematic controller samples it (None: trajectory)


def build(spec: ScenarioSpec) -> Setup:
    """Model, task, initial configuration, trajectory and controller of a scenario."""
    robot = scenario_model(spec.model)
    if spec.phases:
        return build_sequence(robot, spec)
    task, q0, residual = scenario_start(robot, spec)
    trajectory = make_trajectory(Configuration(robot, q0).pose(task.frame_id).copy(), spec.trajectory)
    duration = scenario_duration(spec)
    if spec.plant.type != "kinematic" and spec.plant.thrusters:
        plant = make_plant(robot, spec.plant)
        if spec.excitation.wrench:  # open loop: the thrusters alone, as identification's logs have them
            actuation = scenario_excitation(actuated_plant(plant, fins=False), spec, duration)
            return Setup(robot, task, trajectory, q0, actuation.controller, duration, residual, plant=plant,
                         actuation=actuation)
        if spec.controller.type == "mpc":
            from .mpc import make_mpc_actuation

            actuation = make_mpc_actuation(actuated_plant(plant), task, trajectory, q0, spec)
            return Setup(robot, task, trajectory, q0, actuation.controller, duration, residual, plant=plant,
                         actuation=actuation, inequalities=actuation.inequalities)
        cls = solver_class(spec.solver)
        solver = SolverFactory(cls, robot, solver_options(robot, spec.solver, cls, spec.simulation.dt))
        # the controller asks once per step, at k dt: the table of those times, shared with the recorder
        times = stage_times(check_step_count(spec, duration), float(spec.simulation.dt), "euler")
        samples = RecentSamples(TrajectoryTable(trajectory, times))
        actuation = make_actuation(actuated_plant(plant), task, samples, q0, spec, solver)
        return Setup(robot, task, trajectory, q0, actuation.controller, duration, residual, plant=plant,
                     actuation=actuation, inequalities=actuation.inequalities, samples=samples)
    if spec.plant.type != "kinematic":
        plant, controller, inequalities = make_plant_controller(robot, task, trajectory, spec)
        return Setup(robot, task, trajectory, q0, controller, duration, residual, plant=plant,
                     control_dt=float(spec.plant.control_dt), inequalities=inequalities)
    inequalities = (build_inequalities(robot, spec.inequalities, solver_class(spec.solver).enforces_inequalities)
                    if spec.inequalities else None)
    dt, integrator = float(spec.simulation.dt), spec.simulation.integrator
    times = stage_times(check_step_count(spec, duration), dt, integrator)  # every time the run asks for
    samples = RecentSamples(TrajectoryTable(trajectory, times))  # the controller's stages and the recorder share it
    controller = make_controller(robot, task, samples, spec, inequalities)
    return Setup(robot, task, trajectory, q0, controller, duration, residual, inequalities=inequalities,
                 samples=samples)


def build_sequence(robot: Robot, spec: ScenarioSpec) -> Setup:
    """A [[phases]] scenario: several frames, claws and a claw distance, the vehicle held (uvms.control.sequence)."""
    solver, frames = spec.solver, spec.task.frames or robot.ee_frames
    solver_type = solver_class(solver, any_levels="a sequence scenario")  # levels: vehicle, distance, frames, joints
    if spec.initial.method != "given" or not isinstance(solver.gain, NUMBER):
        raise ScenarioError("a sequence scenario needs initial.method = 'given' and one number for solver.gain")
    q0, _ = initial_q(robot, None, spec)
    phases = [Phase(name=phase.name or f"phase {index + 1}", duration=float(phase.duration),
                    offsets=phase.offsets, joints=phase.joints, distance=phase.distance)
              for index, phase in enumerate(spec.phases)]
    plan = PhasePlan(robot, q0, frames, phases)
    options = solver_options(robot, solver, solver_type, float(spec.simulation.dt))
    try:
        controller = SequenceController(robot, plan, SolverFactory(solver_type, robot, options),
                                        hold_vehicle=spec.vehicle.hold)
    except UVMSError as exc:
        raise ScenarioError(f"solver: {exc}") from None
    return Setup(robot, controller.frame_tasks[0], plan.frame_trajectory(frames[0]), q0, controller,
                 scenario_duration(spec), 0.0, plan)


def scenario_start(robot: Robot, spec: ScenarioSpec) -> tuple[FrameTask | None, np.ndarray, float]:
    """(task (None with [[phases]]), q0 (nq,), its residual) of a checked scenario; ``uvms view SCENARIO`` draws q0."""
    task = None if spec.phases else FrameTask(robot, spec.task.frame or None,
                     axes=spec.task.axes or None, orientation=spec.task.orientation_error)
    return (task, *initial_q(robot, task, spec))


def initial_q(robot: Robot, task: FrameTask | None, spec: ScenarioSpec) -> tuple[np.ndarray, float]:
    """q0 as given, or optimized (hoang2011 sec. 2.3) to put the frame at the trajectory start."""
    initial = spec.initial
    base = initial.base or None
    try:
        q_given = robot.configuration(base=np.array(base) if base else None, arm=initial_arm(robot, initial.arm))
    except UVMSError as exc:
        raise ScenarioError(f"initial.base/initial.arm: {exc}") from None
    fixed = initial.fixed_base
    if initial.method == "given":
        if fixed:
            raise ScenarioError("initial.fixed_base holds vehicle coordinates during the optimization of q0: it needs "
                                "initial.method = 'optimize' (with 'given', initial.base is used as it is)")
        return q_given, 0.0
    trajectory = spec.trajectory
    if not trajectory.start or not trajectory.orientation:
        raise ScenarioError("initial.method = 'optimize' needs trajectory.start and trajectory.orientation")
    if not all(isinstance(name, str) for name in fixed):
        raise ScenarioError(f"initial.fixed_base must be a list of vehicle coordinate names "
                            f"({', '.join(robot.base.pose_names) or 'none: the base is fixed'}), got {thaw(fixed)!r}")
    task.set_target(np.concatenate([trajectory.start, trajectory.orientation]))
    potential = MidRangePotential(robot, weights=np.asarray(spec.solver.joint_limit_weights, dtype=float))
    try:
        result = initial_configuration(robot, task, potential, q_given, fixed_base=fixed)
    except (SolverInputError, NameNotFound) as exc:
        raise ScenarioError(f"initial.fixed_base: {exc} (their values are those of initial.base, 0 where not "
                            f"given)") from None
    if not result.success:
        held = f" with {', '.join(fixed)} held" if fixed else ""
        raise ScenarioError(f"no initial configuration reaches the trajectory start{held} "
                            f"(residual {result.residual:.3g})")
    return result.q, result.residual


def initial_arm(robot: Robot, arm: tuple | dict) -> np.ndarray | None:
    """initial.arm as arm joint values (n_arm,) [rad or m]: the list as given, or a table {joint = value} with the
    joints left out at 0 (their neutral value); None when empty.

    Raises:
        ScenarioError: a table naming a joint that is not an arm joint (the valid ones listed), or a value that is
            not a number.
    """
    if not arm:
        return None
    if isinstance(arm, (list, tuple)):
        return np.array(arm, dtype=float)
    names = robot.arm_joint_names
    values = np.zeros(robot.n_arm)
    for joint, value in arm.items():
        if joint not in names:
            raise ScenarioError(f"initial.arm names {joint!r}, which is not an arm joint; valid: {', '.join(names)}")
        if isinstance(value, bool) or not isinstance(value, NUMBER):
            raise ScenarioError(f"initial.arm.{joint} must be a number [rad or m], got {value!r}")
        values[names.index(joint)] = value
    return values


def make_plant_controller(robot: Robot, task: FrameTask, trajectory,
                          spec: ScenarioSpec) -> tuple[Plant, GJMController, ScenarioInequalities | None]:
    """The plant, the GJM controller (amundsen2018 eq. 4-8) on solver.method and the [[inequalities]] of a
    dynamic [plant] (passive vehicle): the solver built with free_floating on the levels [inequalities (when it
    enforces them, else monitored), task].

    Raises:
        ScenarioError: a method of fixed levels, what the GJM controller refuses (the scenario's checks are the
            spec's: :func:`uvms.scenario.spec.dynamics.check_passive`).
    """
    section, solver = spec.plant, spec.solver
    cls = solver_class(solver)
    plant = make_plant(robot, section)
    gain = np.asarray(solver.gain, dtype=float)
    control_dt, dt = float(section.control_dt), float(spec.simulation.dt)
    inequalities = (build_inequalities(robot, spec.inequalities, cls.enforces_inequalities) if spec.inequalities
                    else None)
    taken = solver_options(robot, solver, cls, control_dt or dt)  # the step: the controller's period
    options = {key: value for key, value in taken.items() if key in ("dt", "priority", "eta", "regularization")}
    try:
        controller = GJMController(robot, trajectory, frame=task.frame, axes=task.axes, gain=gain,
                                   damping=solver_damping(solver), weights=solver_weights(robot, solver, True),
                                   gjm=section.gjm, hydro=plant.hydro if plant.links else None,
                                   motor_feedforward=plant.motor_time_constant if section.motor_feedforward else 0.0,
                                   solver=SolverFactory(cls, robot, options),
                                   levels=inequalities.levels if inequalities and inequalities.enforced else ())
    except UVMSError as exc:
        raise ScenarioError(f"plant/solver ({solver.method}): {exc}") from None
    return plant, controller, inequalities


def solver_class(solver: SolverSpec, any_levels: str = "") -> type[Solver]:
    """The class of solver.method, every [solver] key the user set checked against what it takes: the one place
    a scenario's method is looked up in :data:`uvms.solvers.SOLVERS` (controllers get a SolverFactory of it).

    Args:
        solver: the [solver] section; any_levels: what needs a solver of any number of levels (e.g. a sequence
            scenario), refused a method of a fixed number (""; any method).

    Raises:
        ScenarioError: a method of a fixed number of levels for ``any_levels``; a key set (not at its default)
            that the method's constructor does not take; the message lists the keys it takes.
    """
    method = solver.method
    cls = SOLVERS[method]
    if any_levels and cls.level_count is not None:
        valid = [name for name, other in SOLVERS.items() if other.level_count is None]
        raise ScenarioError(f"{any_levels} needs solver.method in {', '.join(valid)} (a solver of any number of "
                            f"levels), got {method!r}")
    taken = cls.options()
    refused = [key for key in solver.changed(tuple(SOLVER_KEYWORDS))
               if SOLVER_KEYWORDS[key] not in taken]
    if refused:
        keys = ", ".join(f"solver.{key}" for key, keyword in SOLVER_KEYWORDS.items() if keyword in taken)
        hint = ""
        if cls.enforces_inequalities and refused[0] in ("alpha", "enforce_limits"):
            hint = ("; joint limits are an [[inequalities]] table of type 'joint_limits' (margin, band [rad]), "
                    "which it enforces")
        raise ScenarioError(f"solver.{refused[0]} is not used by solver.method = {method!r}, which takes {keys}: "
                            f"remove it or choose another method{hint}")
    return cls


def solver_damping(solver: SolverSpec) -> float | VariableDamping:
    """solver.damping, or the variable damping of amundsen2018 eq. 6 when solver.damping_epsilon > 0."""
    if solver.damping_epsilon > 0:
        return VariableDamping(solver.damping_epsilon, solver.damping_max)
    return solver.damping


def solver_options(robot: Robot, solver: SolverSpec, cls: type[Solver], dt: float) -> dict[str, Any]:
    """The constructor keywords of ``cls`` from the [solver] section (those it takes), with the step dt [s]."""
    offered = {key: getattr(solver, key) for key, keyword in SOLVER_KEYWORDS.items() if key == keyword}
    offered.update(gain=np.asarray(solver.gain, dtype=float), damping=solver_damping(solver), dt=dt)
    offered.pop("weights")  # checked against the model below
    taken = cls.options()
    options = {keyword: value for keyword, value in offered.items() if keyword in taken}
    if "weights" in taken:
        options["weights"] = solver_weights(robot, solver, free_floating=solver.free_floating)
    if "potential" in taken:
        options["potential"] = MidRangePotential(robot, weights=np.asarray(solver.joint_limit_weights,
                                                                             dtype=float))
    return options


def solver_weights(robot: Robot, solver: SolverSpec, free_floating: bool) -> np.ndarray | None:
    """``solver.weights`` as the diagonal W of the solved columns, checked against the model (None: not given).

    The solved columns are v's nv (the vehicle, then the arm), or the n_arm arm joints for free-floating
    (generalized-Jacobian) control, where the vehicle is not commanded.

    Raises:
        ScenarioError: the wrong count (the message says what the entries are), or an entry <= 0.
    """
    if not solver.weights:
        return None
    weights = np.asarray(solver.weights, dtype=float)
    if free_floating:
        size, covered = robot.n_arm, (f"free-floating (generalized-Jacobian) weights cover the arm joints only "
                                      f"({', '.join(robot.arm_joint_names)}); the vehicle is not commanded, it "
                                      f"moves by momentum conservation")
    else:
        vehicle = f"the vehicle ({', '.join(robot.base.pose_names)}) then " if robot.n_vehicle else ""
        size, covered = robot.nv, f"one per velocity coordinate: {vehicle}the arm ({', '.join(robot.arm_joint_names)})"
    if weights.shape != (size,):
        raise ScenarioError(f"solver.weights has {weights.size} numbers, {robot.name} needs {size}: {covered}")
    if np.any(weights <= 0):
        raise ScenarioError(f"solver.weights must all be > 0 (the diagonal of a positive definite W), "
                            f"got {thaw(solver.weights)}")
    return weights


def make_controller(robot: Robot, task: FrameTask, samples: RecentSamples, spec: ScenarioSpec,
                    inequalities: ScenarioInequalities | None = None) -> TrackingController:
    """The tracking controller of the scenario's solver method, following ``samples`` (the trajectory).

    The solver is :func:`solver_class`'s, built once. Its levels: the ``[[inequalities]]`` (highest first)
    when it enforces them (else the recorder monitors them), then the task, and the ``[vehicle]`` task at the
    level the solver puts it (:attr:`~uvms.solvers.base.Solver.vehicle_level`) when it uses one.
    """
    solver, vehicle = spec.solver, spec.vehicle
    cls = solver_class(solver)
    options = solver_options(robot, solver, cls, spec.simulation.dt)
    levels: list = [*(inequalities.levels if inequalities is not None and cls.enforces_inequalities else []), task]
    if cls.vehicle_level is not None:
        if not vehicle.velocities and vehicle.heading is None and vehicle.depth is None:
            raise ScenarioError(f"solver.method = {solver.method!r} needs a [vehicle] task (velocities, heading or "
                                f"depth)")
        levels.insert(cls.vehicle_level, VehicleTask(robot, velocities=vehicle.velocities,
                                                     heading=vehicle.heading, depth=vehicle.depth))
        gains: list = [options["gain"]] * (len(levels) - 1)
        gains.insert(cls.vehicle_level, vehicle.gain)
        options["gain"] = gains
    try:
        return TrackingController(robot, task, samples, SolverFactory(cls, robot, options), levels)
    except UVMSError as exc:
        raise ScenarioError(f"solver ({solver.method}): {exc}") from None


def check_step_count(spec: ScenarioSpec, duration: float) -> int:
    """The number of steps of a run, checked before it starts (:func:`uvms.numerics.integrate.step_count`)."""
    if spec.simulation.duration:
        duration_name = "simulation.duration"
    else:
        duration_name = "the phases' durations" if spec.phases else "trajectory.duration"
    return step_count(duration, float(spec.simulation.dt), dt_name="simulation.dt",
                      duration_name=duration_name)


def scenario_duration(spec: ScenarioSpec) -> float:
    """The simulated time [s] a checked scenario asks for, from its tables alone (nothing built):
    ``simulation.duration``, else the sum of the phases' durations, else ``trajectory.duration`` (every trajectory
    type lasts that long)."""
    if spec.simulation.duration:
        return float(spec.simulation.duration)
    if spec.phases:
        return float(sum(phase.duration for phase in spec.phases))
    return float(spec.trajectory.duration)
