"""An actuated vehicle's controller (plant.thrusters): the whole chain, any solver, inequalities, task and trajectory.

``[plant] type = "hydrodynamic"`` with ``thrusters = true`` runs :func:`uvms.control.station.actuated_control`
with :func:`uvms.sim.loop.simulate` on an ``ActuatedPlant``: the scenario's solver (any ``solver.method``, its
``[[inequalities]]`` enforced above the task when it enforces them) with the vehicle's pose objective gives the
reference; its vehicle part is the velocity loop's setpoint (the plant's own Fossen model as feedforward, PI
feedback); with ``vehicle_control.coordination`` the arm is solved again through the same solver with the
measured vehicle velocity held; the allocation turns the wrench into thrusts within the thrusters' limits
(``vehicle_control.saturation_feedback``: its shortfall bounds the vehicle's part of the next reference), and the
plant simulates their first-order response. The thrusters are model data
(:func:`uvms.dynamics.thrusters.thrusters.thrusters_of`). Station keeping is ``trajectory.type = "hold"``.
"""

from __future__ import annotations

from ...control.reference import TaskReference
from ...control.station import actuated_control
from ...dynamics.plant.actuated import ActuatedPlant
from ...errors import ScenarioError, UVMSError
from ...solvers.base import SolverFactory
from ..actuated import Actuation
from ..inequalities import ScenarioInequalities
from ..spec import ScenarioSpec
from .parts import Parts, Setup, scenario_levels


def build_actuated(spec: ScenarioSpec, parts: Parts) -> Setup:
    """The chain on the actuated plant, its solver asked once per step (the trajectory sampled at those times once,
    shared with the recorder)."""
    dt = float(spec.simulation.dt)
    solver, inequalities = scenario_levels(spec, parts.robot, dt)
    samples = parts.samples(dt, "euler")
    actuation = make_actuation(parts.actuated, TaskReference(parts.task, samples), spec, solver, inequalities)
    return parts.setup(actuation.controller, inequalities=inequalities, actuation=actuation, samples=samples)


def make_actuation(actuated: ActuatedPlant, reference: TaskReference, spec: ScenarioSpec, solver: SolverFactory,
                   inequalities: ScenarioInequalities | None) -> Actuation:
    """The whole chain of the scenario on ``actuated`` (:func:`uvms.control.station.actuated_control`).

    Args:
        solver: the scenario's solver, built on the chain's levels (a solver without priorities, CLIK: the
            vehicle's velocity given as fixed columns). inequalities: the scenario's, levels above the task when
            the solver enforces them, else monitored.
    """
    section, cls = spec.solver, solver.cls
    if not cls.holds_priorities and (section.alpha or section.enforce_limits or section.weights
                                     or section.damping_epsilon):
        raise ScenarioError(f"plant.thrusters = true with solver.method = {section.method!r}: it has no priorities "
                            "to hold the vehicle's velocity above the task, so the arm is solved with the vehicle's "
                            "velocity given as fixed columns: J_a^# (K e + xdot_d - J_v nu) (solver.gain, a fixed "
                            "solver.damping); solver.alpha, enforce_limits, weights and damping_epsilon are not "
                            "supported there. For joint limits use solver.method = 'set_based' or 'hqp' with an "
                            "[[inequalities]] joint_limits table")
    enforced = inequalities.levels if inequalities is not None and inequalities.enforced else ()
    try:
        controller = actuated_control(actuated, float(spec.simulation.dt), reference, solver,
                                      spec.vehicle_control.settings, inequalities=enforced)
    except UVMSError as exc:
        raise ScenarioError(f"vehicle_control/solver: {exc}") from None
    return Actuation(actuated, controller, inequalities)
