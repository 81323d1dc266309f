"""What a scenario's controller is built from and what its build gives: :class:`Parts` (made once by
:func:`uvms.scenario.build.build`, before the controller) and :class:`Setup` (everything a run needs)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ...control.sequence import PhasePlan
from ...dynamics.plant.actuated import ActuatedPlant
from ...dynamics.plant.plant import Plant
from ...numerics.integrate import stage_times
from ...robot.robot import Robot
from ...solvers.base import SolverFactory
from ...tasks import FrameTask
from ...trajectory import PathTrajectory, RecentSamples, SE3Trajectory, TrajectoryTable
from ..actuated import Actuation
from ..inequalities import ScenarioInequalities, build_inequalities
from ..solver import scenario_solver
from ..spec import ScenarioSpec


@dataclass
class Setup:
    """Everything a run needs, built from a validated scenario."""

    robot: Robot
    task: FrameTask | None
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


@dataclass(frozen=True)
class Parts:
    """What :func:`uvms.scenario.build.build` makes once from a scenario, in this order, for the builder of its
    controller (:data:`uvms.scenario.controllers.CONTROLLERS`).

    Attributes:
        robot: the model; duration: the simulated time [s]; steps: its steps of simulation.dt.
        task: the ``[task]`` (None for a sequence scenario, whose phases name the frames); q0: the initial
            configuration (nq,); residual: its residual (0 when given); trajectory: what the task follows (None for
            a sequence scenario).
        plant: the free-floating plant of a dynamic ``[plant]`` (None: kinematic); actuated: it with its thrusters
            (plant.thrusters; None otherwise).
    """

    robot: Robot
    duration: float
    steps: int
    task: FrameTask | None
    q0: np.ndarray
    residual: float
    trajectory: PathTrajectory | SE3Trajectory | None
    plant: Plant | None
    actuated: ActuatedPlant | None

    def setup(self, controller: Any, **built: Any) -> Setup:
        """The run of ``controller`` on these parts; ``built``: the Setup fields the builder made (inequalities,
        actuation, samples, ... or a task and trajectory of its own)."""
        made = {"robot": self.robot, "task": self.task, "trajectory": self.trajectory, "q0": self.q0,
                "duration": self.duration, "initial_residual": self.residual, "plant": self.plant}
        return Setup(controller=controller, **{**made, **built})

    def samples(self, dt: float, integrator: str) -> RecentSamples:
        """The trajectory at the times a controller asks it, once for the run (every stage of ``integrator`` over
        steps of dt [s]), shared with the recorder."""
        return RecentSamples(TrajectoryTable(self.trajectory, stage_times(self.steps, dt, integrator)))


def scenario_levels(spec: ScenarioSpec, robot: Robot, dt: float) -> tuple[SolverFactory, ScenarioInequalities | None]:
    """The ``[solver]`` of a controller that runs every dt [s] (:func:`uvms.scenario.solver.scenario_solver`) and the
    ``[[inequalities]]`` (None: none), enforced above the task when the solver enforces them, else monitored."""
    solver = scenario_solver(robot, spec.solver, dt)
    enforced = solver.cls.enforces_inequalities
    return solver, build_inequalities(robot, spec.inequalities, enforced) if spec.inequalities else None
