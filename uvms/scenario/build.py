"""Building a run from a checked scenario: model, step count, start, plant, then the controller's builder."""

from __future__ import annotations

import numpy as np

from ..dynamics.plant.actuated import ActuatedPlant
from ..dynamics.plant.plant import Plant
from ..errors import NameNotFound, ScenarioError, SolverInputError, UVMSError
from ..numerics.integrate import step_count
from ..robot.configuration import Configuration
from ..robot.robot import Robot
from ..solvers import initial_configuration
from ..tasks import FrameTask, MidRangePotential
from ..trajectory import PathTrajectory, SE3Trajectory
from .controllers import CONTROLLERS, Parts, Setup
from .record import scenario_model
from .spec import PlantSpec, ScenarioSpec


def build(spec: ScenarioSpec) -> Setup:
    """The run of a checked scenario: its model, step count, start (task, initial configuration, trajectory) and
    plant (with its thrusters), each made once and in that order, then the controller of
    :attr:`~uvms.scenario.spec.ScenarioSpec.controller_kind` built on them by its builder in
    :data:`uvms.scenario.controllers.CONTROLLERS`.

    Raises:
        ScenarioError: what the model, the start, the plant or the controller refuse, with the key's path;
        StepCountError: a run of no step or of too many (before anything is built).
    """
    robot = scenario_model(spec.model)
    duration = scenario_duration(spec)
    steps = check_step_count(spec, duration)  # a run of no step, or of too many, fails before anything is built
    task, q0, residual = scenario_start(robot, spec)
    trajectory = scenario_trajectory(robot, spec, task, q0)
    kind = spec.controller_kind
    plant, actuated = scenario_plant(robot, spec.plant, fins=kind != "excitation")  # an excitation: thrusters alone
    return CONTROLLERS[kind](spec, Parts(robot, duration, steps, task, q0, residual, trajectory, plant, actuated))


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


def scenario_start(robot: Robot, spec: ScenarioSpec) -> tuple[FrameTask | None, np.ndarray, float]:
    """(task (None with [[phases]]), q0 (nq,), its residual) of a checked scenario; ``uvms view SCENARIO`` draws q0."""
    task = None if spec.phases else FrameTask(robot, spec.task.frame or None,
                     axes=spec.task.axes or None, orientation=spec.task.orientation_error)
    return (task, *initial_q(robot, task, spec))


def scenario_trajectory(robot: Robot, spec: ScenarioSpec, task: FrameTask | None,
                        q0: np.ndarray) -> PathTrajectory | SE3Trajectory | None:
    """What the task follows: the ``[trajectory]`` from the pose of the task's frame at q0 (None for a sequence
    scenario, whose phases make their own)."""
    if spec.phases:
        return None
    return spec.trajectory.settings.trajectory(Configuration(robot, q0).pose(task.frame_id).copy())


def initial_q(robot: Robot, task: FrameTask | None, spec: ScenarioSpec) -> tuple[np.ndarray, float]:
    """q0 as given, or optimized (hoang2011 sec. 2.3) to put the frame at the trajectory start (what the sections
    need of each other is checked where the file is read: :func:`uvms.scenario.spec.scenario.check_initial`; a
    sequence scenario's q0 is given)."""
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
