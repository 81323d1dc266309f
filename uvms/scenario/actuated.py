"""The run side of an actuated scenario: :class:`Actuation` (the plant with its thrusters and the controller that
drives them: built by :mod:`uvms.scenario.controllers`), its simulation and its metrics.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..control.base import Controller
from ..control.coordination import CoordinatedControl
from ..control.station import ActuatedKinematics
from ..dynamics.plant.actuated import ActuatedPlant
from ..dynamics.plant.plant import Plant
from ..dynamics.thrusters.fins import Fins
from ..dynamics.thrusters.thrusters import Thrusters
from ..robot.robot import Robot
from ..sim.loop import simulate
from ..sim.result import SimulationResult
from ..tasks.frame import FrameTask
from ..trajectory.table import pose_function
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


class ActuatedObjectives:
    """The inequality series of an actuated row (:class:`uvms.scenario.inequalities.ObjectiveRecorder` on the
    measured state, the solver's activity from the kinematic reference).

    Args:
        robot, inequalities: as the recorder's.
        kinematic: the chain's reference (:class:`uvms.control.station.ActuatedKinematics`), whose step's rows at
            the measured q are read rather than evaluated again; None (another controller): evaluated here.
    """

    def __init__(self, robot: Robot, inequalities: ScenarioInequalities,
                 kinematic: ActuatedKinematics | None = None) -> None:
        self.recorder = ObjectiveRecorder(robot, inequalities, None if kinematic is None else kinematic.objective_rows)

    def __call__(self, t: float, q: np.ndarray, x: np.ndarray, sample: object) -> dict:
        info = sample.command.info.get("solver")
        recorder = self.recorder
        return recorder.row(q, sample.rate[0], getattr(info, "activity", None),
                            None if recorder.evaluated is None else recorder.evaluated(q))


def simulate_actuation(actuation: Actuation, task: FrameTask, trajectory, q0: np.ndarray, duration: float,
                       simulation: SimulationSpec, progress: bool | None) -> SimulationResult:
    """The run, with the task series (the end effector against the held point) recorded."""
    controller = actuation.controller
    kinematic = controller.kinematic if isinstance(controller, CoordinatedControl) else None
    recorders = [] if actuation.inequalities is None else [ActuatedObjectives(actuation.plant.robot,
                                                                                  actuation.inequalities, kinematic)]
    return simulate(actuation.actuated, actuation.controller, q0, duration, float(simulation.dt),
                    integrator=simulation.integrator, task=task, desired=pose_function(trajectory),
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
