"""The kinematic plant's controller: the ``[solver]`` tracking the trajectory
(:class:`uvms.control.tracking.TrackingController`)."""

from __future__ import annotations

from ...control.reference import TaskReference
from ...control.tracking import TrackingController
from ...errors import ScenarioError, UVMSError
from ...solvers.base import SolverFactory
from ...tasks import VehicleTask
from ..inequalities import ScenarioInequalities
from ..spec import ScenarioSpec
from .parts import Parts, Setup, scenario_levels


def build_tracking(spec: ScenarioSpec, parts: Parts) -> Setup:
    """Kinematic tracking: the solver asked at every integrator stage, the trajectory sampled at those times once
    (:meth:`Parts.samples`, shared with the recorder)."""
    dt = float(spec.simulation.dt)
    solver, inequalities = scenario_levels(spec, parts.robot, dt)
    samples = parts.samples(dt, spec.simulation.integrator)
    controller = tracking_controller(TaskReference(parts.task, samples), spec, solver, inequalities)
    return parts.setup(controller, inequalities=inequalities, samples=samples)


def tracking_controller(reference: TaskReference, spec: ScenarioSpec, solver: SolverFactory,
                        inequalities: ScenarioInequalities | None = None) -> TrackingController:
    """The tracking controller of the scenario's solver (:func:`~uvms.scenario.solver.scenario_solver`), its task
    following the reference's trajectory, built once. Its levels: the ``[[inequalities]]`` (highest first)
    when it enforces them (else the recorder monitors them), then the task, and the ``[vehicle]`` task at the
    level the solver puts it (:attr:`~uvms.solvers.base.Solver.vehicle_level`) when it uses one.
    """
    robot, vehicle, cls = solver.robot, spec.vehicle, solver.cls
    options = dict(solver.options)
    task = reference.task
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
        return TrackingController(robot, reference, SolverFactory(cls, robot, options), levels)
    except UVMSError as exc:
        raise ScenarioError(f"solver ({spec.solver.method}): {exc}") from None
