"""A scenario whose vehicle is actuated by thrusters: the whole chain, any solver, inequalities, task and trajectory.

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

from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np

from ..control.base import Controller
from ..control.coordination import CoordinatedControl
from ..control.station import actuated_control
from ..dynamics.plant.actuated import ActuatedPlant
from ..dynamics.plant.plant import Plant
from ..dynamics.thrusters.fins import Fins
from ..dynamics.thrusters.thrusters import Thrusters
from ..errors import ScenarioError, UVMSError
from ..robot.robot import Robot
from ..sim.loop import simulate
from ..sim.result import SimulationResult
from ..solvers.base import SolverFactory
from ..tasks.frame import FrameTask
from .inequalities import ObjectiveRecorder, ScenarioInequalities
from .spec import ScenarioSpec, SimulationSpec


@dataclass
class Actuation:
    """The actuated part of a run: the plant with its thrusters (and fins), and the controller that drives them."""

    actuated: ActuatedPlant
    controller: CoordinatedControl | Controller  # the chain, the MPC (controller.type = "mpc") or an excitation
    inequalities: ScenarioInequalities | None = None

    @property
    def plant(self) -> Plant:
        return self.actuated.plant

    @property
    def thrusters(self) -> Thrusters:
        return self.actuated.thrusters

    @property
    def fins(self) -> Fins:
        return self.actuated.fins


def make_actuation(actuated: ActuatedPlant, task: FrameTask, trajectory, spec: ScenarioSpec, solver: SolverFactory,
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
        controller = actuated_control(actuated, float(spec.simulation.dt), task, trajectory, solver,
                                      spec.vehicle_control.settings, inequalities=enforced)
    except UVMSError as exc:
        raise ScenarioError(f"vehicle_control/solver: {exc}") from None
    return Actuation(actuated, controller, inequalities)


class ActuatedObjectives:
    """The inequality series of an actuated row (:class:`uvms.scenario.inequalities.ObjectiveRecorder` on the
    measured state, the solver's activity from the kinematic reference)."""

    def __init__(self, robot: Robot, inequalities: ScenarioInequalities) -> None:
        self.recorder = ObjectiveRecorder(robot, inequalities)

    def __call__(self, t: float, q: np.ndarray, x: np.ndarray, sample: object) -> dict:
        view = SimpleNamespace(rate=sample.rate, info=sample.command.info.get("solver"))
        return self.recorder(t, q, x, view)


def simulate_actuation(actuation: Actuation, task: FrameTask, trajectory, q0: np.ndarray, duration: float,
                       simulation: SimulationSpec, progress: bool | None) -> SimulationResult:
    """The run, with the task series (the end effector against the held point) recorded."""
    recorders = [] if actuation.inequalities is None else [ActuatedObjectives(actuation.plant.robot,
                                                                                  actuation.inequalities)]
    return simulate(actuation.actuated, actuation.controller, q0, duration, float(simulation.dt),
                    integrator=simulation.integrator, task=task, desired=lambda t: trajectory(t).pose,
                    progress=progress, recorders=recorders)


def actuated_metrics(result: SimulationResult, actuation: Actuation, spec: ScenarioSpec) -> dict:
    """``metrics.json``'s actuated entries: the thrusters' (:meth:`uvms.sim.result.SimulationResult.actuation_metrics`)
    and what the run was (thruster count, current; the chain's coordination, or the MPC's solve times and iterations,
    its ``metrics()``)."""
    fins = {"fins": actuation.fins.names} if len(actuation.fins) else {}
    common = {**result.actuation_metrics(), "plant": "hydrodynamic", "thrusters": actuation.thrusters.names, **fins,
              "current": list(spec.plant.current) or [0.0, 0.0, 0.0]}
    if spec.controller.type == "mpc":
        return {**common, "controller": "mpc", "mpc": actuation.controller.metrics()}
    return {**common, "coordination": bool(spec.vehicle_control.coordination),
            "saturation_feedback": bool(spec.vehicle_control.saturation_feedback)}
