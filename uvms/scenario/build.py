"""Building a run from a checked scenario: model, task, initial configuration, trajectory, controller, plant."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..control.gjm import GJMController
from ..control.sequence import Phase, PhasePlan, SequenceController
from ..control.tracking import TrackingController
from ..dynamics.plant.actuated import ActuatedPlant
from ..dynamics.plant.plant import Plant
from ..errors import NameNotFound, ScenarioError, SolverInputError, UVMSError
from ..numerics.integrate import stage_times, step_count
from ..robot.configuration import Configuration
from ..robot.robot import Robot
from ..solvers import initial_configuration
from ..solvers.base import SolverFactory
from ..tasks import FrameTask, MidRangePotential, VehicleTask
from ..trajectory import PathTrajectory, RecentSamples, SE3Trajectory, TrajectoryTable
from .actuated import Actuation, make_actuation
from .excitation import scenario_excitation
from .inequalities import ScenarioInequalities, build_inequalities
from .record import scenario_model
from .solver import scenario_solver, solver_damping, solver_weights
from .spec import NUMBER, PlantSpec, ScenarioSpec


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
    """Model, step count, task, initial configuration, trajectory, plant (with its thrusters), solver and
    inequalities of a scenario, each made once and in that order, then the controller its plant needs: an open-loop
    excitation, the MPC, the actuated chain, the GJM controller of a passive vehicle or kinematic tracking."""
    robot = scenario_model(spec.model)
    duration = scenario_duration(spec)
    steps = check_step_count(spec, duration)  # a run of no step, or of too many, fails before anything is built
    if spec.phases:
        return build_sequence(robot, spec, duration)
    task, q0, residual = scenario_start(robot, spec)
    trajectory = spec.trajectory.settings.trajectory(Configuration(robot, q0).pose(task.frame_id).copy())
    section, dt = spec.plant, spec.simulation.dt
    open_loop = section.thrusters and bool(spec.excitation.wrench)
    plant, actuated = scenario_plant(robot, section, fins=not open_loop)
    passive = plant is not None and actuated is None
    actuation = samples = inequalities = None
    if open_loop:  # the thrusters alone, as identification's logs have them
        actuation = scenario_excitation(actuated, spec, duration)
    elif actuated is not None and spec.controller.type == "mpc":
        from .mpc import make_mpc_actuation

        actuation = make_mpc_actuation(actuated, task, trajectory, q0, spec)
        inequalities = actuation.inequalities
    else:  # the scenario's solver: on the GJM controller's period, or the step
        solver = scenario_solver(robot, spec.solver, (float(section.control_dt) or float(dt)) if passive else dt)
        inequalities = (build_inequalities(robot, spec.inequalities, solver.cls.enforces_inequalities)
                        if spec.inequalities else None)
        if passive:
            controller = make_plant_controller(plant, task, trajectory, spec, solver, inequalities)
        else:  # the times the controller asks (once per step with thrusters), shared with the recorder
            times = stage_times(steps, float(dt), "euler" if actuated is not None else spec.simulation.integrator)
            samples = RecentSamples(TrajectoryTable(trajectory, times))
            if actuated is not None:
                actuation = make_actuation(actuated, task, samples, spec, solver, inequalities)
            else:
                controller = make_controller(task, samples, spec, solver, inequalities)
    return Setup(robot, task, trajectory, q0, controller if actuation is None else actuation.controller, duration,
                 residual, plant=plant, control_dt=float(section.control_dt) if passive else 0.0,
                 inequalities=inequalities, actuation=actuation, samples=samples)


def scenario_plant(robot: Robot, section: PlantSpec, *, fins: bool) -> tuple[Plant | None, ActuatedPlant | None]:
    """The free-floating plant of a dynamic ``[plant]`` (:meth:`uvms.dynamics.plant.plant.Plant.from_settings`) and,
    with plant.thrusters, the plant with the model's thrusters (and with ``fins`` its fins:
    :meth:`uvms.dynamics.plant.actuated.ActuatedPlant.of`); None on the kinematic plant.

    Raises:
        ScenarioError: what they refuse of the model, with the key's path (a fixed base, a hydrodynamics file not of
            this model, a hydrodynamic plant of a model without hydrodynamic parameters; thrusters on a vehicle
            that is not floating, a model without thrusters, a thruster on an arm link).
    """
    if section.settings is None:
        return None, None
    try:
        plant = Plant.from_settings(robot, section.settings)
    except UVMSError as exc:
        raise ScenarioError(f"plant.{exc}") from None
    if not section.thrusters:
        return plant, None
    if robot.base_type != "floating":  # the actuated chain holds six degrees of freedom
        raise ScenarioError(f"plant.thrusters = true needs a floating vehicle; {robot.name} has a {robot.base_type} "
                            f"base")
    try:
        return plant, ActuatedPlant.of(plant, fins=fins)
    except UVMSError as exc:
        raise ScenarioError(f"plant.thrusters = true: {exc}") from None


def build_sequence(robot: Robot, spec: ScenarioSpec, duration: float) -> Setup:
    """A [[phases]] scenario: several frames, claws and a claw distance, the vehicle held (uvms.control.sequence)."""
    solver, frames = spec.solver, spec.task.frames or robot.ee_frames
    # levels: vehicle, distance, frames, joints
    factory = scenario_solver(robot, solver, float(spec.simulation.dt), any_levels="a sequence scenario")
    if spec.initial.method != "given" or not isinstance(solver.gain, NUMBER):
        raise ScenarioError("a sequence scenario needs initial.method = 'given' and one number for solver.gain")
    q0, _ = initial_q(robot, None, spec)
    phases = [Phase(name=phase.name or f"phase {index + 1}", duration=float(phase.duration),
                    offsets=phase.offsets, joints=phase.joints, distance=phase.distance)
              for index, phase in enumerate(spec.phases)]
    plan = PhasePlan(robot, q0, frames, phases)
    try:
        controller = SequenceController(robot, plan, factory, hold_vehicle=spec.vehicle.hold)
    except UVMSError as exc:
        raise ScenarioError(f"solver: {exc}") from None
    return Setup(robot, controller.frame_tasks[0], plan.frame_trajectory(frames[0]), q0, controller, duration, 0.0,
                 plan)


def scenario_start(robot: Robot, spec: ScenarioSpec) -> tuple[FrameTask | None, np.ndarray, float]:
    """(task (None with [[phases]]), q0 (nq,), its residual) of a checked scenario; ``uvms view SCENARIO`` draws q0."""
    task = None if spec.phases else FrameTask(robot, spec.task.frame or None,
                     axes=spec.task.axes or None, orientation=spec.task.orientation_error)
    return (task, *initial_q(robot, task, spec))


def initial_q(robot: Robot, task: FrameTask | None, spec: ScenarioSpec) -> tuple[np.ndarray, float]:
    """q0 as given, or optimized (hoang2011 sec. 2.3) to put the frame at the trajectory start (what the sections
    need of each other is checked where the file is read: :func:`uvms.scenario.spec.scenario.check_initial`)."""
    initial = spec.initial
    try:
        q_given = robot.configuration(base=np.array(initial.base) if initial.base else None,
                                      arm=initial.arm or None)
    except UVMSError as exc:
        raise ScenarioError(f"initial.base/initial.arm: {exc}") from None
    if initial.method == "given":
        return q_given, 0.0
    task.set_target(np.concatenate([spec.trajectory.start, spec.trajectory.orientation]))
    potential = MidRangePotential(robot, weights=np.asarray(spec.solver.joint_limit_weights, dtype=float))
    fixed = initial.fixed_base
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


def make_plant_controller(plant: Plant, task: FrameTask, trajectory, spec: ScenarioSpec, solver: SolverFactory,
                          inequalities: ScenarioInequalities | None) -> GJMController:
    """The GJM controller (amundsen2018 eq. 4-8) of a dynamic [plant] without thrusters (a passive vehicle) on the
    scenario's solver (built with free_floating on the levels [inequalities (when it enforces them, else monitored),
    task]); the scenario's checks are the spec's (:func:`uvms.scenario.spec.dynamics.check_passive`).

    Raises:
        ScenarioError: what the GJM controller refuses.
    """
    section, robot = spec.plant, plant.robot
    taken = ("dt", "priority", "eta", "regularization")  # the rest the controller sets itself
    options = {key: value for key, value in solver.options.items() if key in taken}
    try:
        return GJMController(robot, trajectory, frame=task.frame, axes=task.axes,
                             gain=np.asarray(spec.solver.gain, dtype=float), damping=solver_damping(spec.solver),
                             weights=solver_weights(robot, spec.solver, True), gjm=section.gjm,
                             hydro=plant.hydro if plant.links else None,
                             motor_feedforward=plant.motor_time_constant if section.motor_feedforward else 0.0,
                             solver=SolverFactory(solver.cls, robot, options),
                             levels=inequalities.levels if inequalities and inequalities.enforced else ())
    except UVMSError as exc:
        raise ScenarioError(f"plant/solver ({spec.solver.method}): {exc}") from None


def make_controller(task: FrameTask, samples: RecentSamples, spec: ScenarioSpec, solver: SolverFactory,
                    inequalities: ScenarioInequalities | None = None) -> TrackingController:
    """The tracking controller of the scenario's solver (:func:`~uvms.scenario.solver.scenario_solver`), following
    ``samples`` (the trajectory), built once. Its levels: the ``[[inequalities]]`` (highest first)
    when it enforces them (else the recorder monitors them), then the task, and the ``[vehicle]`` task at the
    level the solver puts it (:attr:`~uvms.solvers.base.Solver.vehicle_level`) when it uses one.
    """
    robot, vehicle, cls = solver.robot, spec.vehicle, solver.cls
    options = dict(solver.options)
    levels: list = [*(inequalities.levels if inequalities is not None and cls.enforces_inequalities else []), task]
    if cls.vehicle_level is not None:
        if not vehicle.velocities and vehicle.heading is None and vehicle.depth is None:
            raise ScenarioError(f"solver.method = {spec.solver.method!r} needs a [vehicle] task (velocities, "
                                f"heading or depth)")
        levels.insert(cls.vehicle_level, VehicleTask(robot, velocities=vehicle.velocities,
                                                     heading=vehicle.heading, depth=vehicle.depth))
        gains: list = [options["gain"]] * (len(levels) - 1)
        gains.insert(cls.vehicle_level, vehicle.gain)
        options["gain"] = gains
    try:
        return TrackingController(robot, task, samples, SolverFactory(cls, robot, options), levels)
    except UVMSError as exc:
        raise ScenarioError(f"solver ({spec.solver.method}): {exc}") from None


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
