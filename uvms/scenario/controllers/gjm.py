"""A passive vehicle's controller (a dynamic ``[plant]`` without thrusters): the GJM controller
(:class:`uvms.control.gjm.GJMController`, amundsen2018 eq. 4-8) on the ``[solver]``, every ``plant.control_dt``."""

from __future__ import annotations

import numpy as np

from ...control.gjm import GJMController
from ...errors import ScenarioError, UVMSError
from ...solvers.base import SolverFactory
from ..solver import solver_damping, solver_weights
from ..spec import ScenarioSpec
from .parts import Parts, Setup, scenario_levels


def build_gjm(spec: ScenarioSpec, parts: Parts) -> Setup:
    """The GJM controller of the passive plant, its solver built on the controller's period (plant.control_dt, or
    simulation.dt when continuous) with free_floating on the levels [inequalities (when it enforces them, else
    monitored), task]; the scenario's checks are the spec's (:func:`uvms.scenario.spec.dynamics.check_passive`).

    Raises:
        ScenarioError: what the GJM controller refuses.
    """
    section, plant, task = spec.plant, parts.plant, parts.task
    control_dt = float(section.control_dt)
    solver, inequalities = scenario_levels(spec, parts.robot, control_dt or float(spec.simulation.dt))
    taken = ("dt", "priority", "eta", "regularization")  # the rest the controller sets itself
    options = {key: value for key, value in solver.options.items() if key in taken}
    try:
        controller = GJMController(
            plant.robot, parts.trajectory, frame=task.frame, axes=task.axes,
            gain=np.asarray(spec.solver.gain, dtype=float), damping=solver_damping(spec.solver),
            weights=solver_weights(plant.robot, spec.solver, True), gjm=section.gjm,
            hydro=plant.hydro if plant.links else None,
            motor_feedforward=plant.motor_time_constant if section.motor_feedforward else 0.0,
            solver=SolverFactory(solver.cls, plant.robot, options),
            levels=inequalities.levels if inequalities and inequalities.enforced else ())
    except UVMSError as exc:
        raise ScenarioError(f"plant/solver ({spec.solver.method}): {exc}") from None
    return parts.setup(controller, control_dt=control_dt, inequalities=inequalities)
