"""Building a run from a checked scenario: step count, model, start, plant, then the controller's builder."""

from __future__ import annotations

import numpy as np

from ..dynamics.plant.actuated import ActuatedPlant
from ..dynamics.plant.plant import Plant
from ..errors import NameNotFound, ScenarioError, SolverInputError, UVMSError
from ..robot.configuration import Configuration
from ..robot.robot import Robot
from ..solvers import initial_configuration
from ..tasks import FrameTask, MidRangePotential
from ..trajectory import PathTrajectory, SE3Trajectory
from .controllers import CONTROLLERS, Parts, Setup
from .record import scenario_model
from .spec import PlantSpec, ScenarioSpec


def build(spec: ScenarioSpec) -> Setup:
    """The run of a checked scenario: its step count, model, start (task, initial configuration, trajectory) and
    plant (with its thrusters), each made once and in that order, then the controller of
    :attr:`~uvms.scenario.spec.ScenarioSpec.controller_kind` built on them by its builder in
    :data:`uvms.scenario.controllers.CONTROLLERS`.

    Raises:
        ScenarioError: what the model, the start, the plant or the controller refuse, with the key's path;
        StepCountError: a run of no step or of too many (before anything is built).
    """
    steps = spec.step_count()  # a run of no step, or of too many, fails before anything is built
    robot = scenario_model(spec.model)
    task, q0, residual, trajectory = scenario_start(robot, spec)
    kind = spec.controller_kind
    plant, actuated = scenario_plant(robot, spec.plant, fins=kind != "excitation")  # an excitation: thrusters alone
    return CONTROLLERS[kind](spec, Parts(robot, spec.duration, steps, task, q0, residual, trajectory, plant,
                                         actuated))


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


def scenario_start(robot: Robot, spec: ScenarioSpec) -> tuple[FrameTask | None, np.ndarray, float,
                                                         PathTrajectory | SE3Trajectory | None]:
    """Where a run starts and what it follows: the task (None with [[phases]]), q0 (nq,) and its residual
    (:func:`initial_q`; ``uvms view SCENARIO`` draws q0), and the ``[trajectory]`` from the pose of the task's frame
    at q0 (None with [[phases]], whose plan makes its own)."""
    if spec.phases:
        return (None, *initial_q(robot, None, spec), None)
    task = FrameTask(robot, spec.task.frame or None, axes=spec.task.axes or None,
                     orientation=spec.task.orientation_error)
    q0, residual = initial_q(robot, task, spec)
    return task, q0, residual, spec.trajectory.settings.trajectory(Configuration(robot, q0).pose(task.frame_id).copy())


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
