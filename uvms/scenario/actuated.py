"""A scenario whose vehicle is actuated by its thrusters: station keeping with the end effector held at a point.

``[plant] type = "hydrodynamic"`` with ``thrusters = true`` runs the whole chain of
:func:`uvms.control.station.station_keeping` with :func:`uvms.sim.loop.simulate` on an ``ActuatedPlant``:
the vehicle pose loop and the end-effector point task give the vehicle and arm references; with
``vehicle_control.coordination`` the arm is solved again with the measured vehicle velocity; the vehicle
velocity loop (the plant's own Fossen model as feedforward, PI feedback) gives a body wrench, the allocation
turns it into thrusts within the thrusters' limits, and the plant simulates their first-order response. The
thrusters are model data (:func:`uvms.dynamics.thrusters.thrusters_of`: uuv_simulator plugins or a
``thrusters.yaml`` beside the model). The end effector holds ``trajectory.start`` (``trajectory.type = "hold"``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..control.coordination import CoordinatedControl
from ..control.station import station_keeping
from ..dynamics.actuated import ActuatedPlant
from ..dynamics.plant import Plant
from ..dynamics.thrusters import Thrusters, thrusters_of
from ..errors import ScenarioError, UVMSError
from ..robot.robot import Robot
from ..solvers import SOLVERS, CLIKSolver
from ..sim.loop import simulate
from ..sim.result import SimulationResult
from ..tasks.frame import FrameTask
from .schema import changed_keys

#: The wrench axes the allocation priorities name (body FLU: forces, then moments).
WRENCH_AXES = ("x", "y", "z", "roll", "pitch", "yaw")


@dataclass
class Actuation:
    """The actuated part of a run: the plant, its thrusters and the station-keeping controller."""

    plant: Plant
    thrusters: Thrusters
    controller: CoordinatedControl


def check_actuated_scenario(robot: Robot, task: FrameTask, scenario: dict) -> None:
    """Refuse what station keeping does not do (a clear message per case)."""
    plant, solver = scenario["plant"], scenario["solver"]
    if plant["type"] != "hydrodynamic":
        raise ScenarioError(f"plant.thrusters = true needs plant.type = 'hydrodynamic' (thrusters push against "
                            f"water), got {plant['type']!r}")
    if robot.base_type != "floating":
        raise ScenarioError(f"plant.thrusters = true needs a floating vehicle; {robot.name} has a {robot.base_type} "
                            f"base")
    if scenario["trajectory"]["type"] != "hold":
        raise ScenarioError("plant.thrusters = true keeps station: the end effector holds a point, so it needs "
                            "trajectory.type = 'hold' (trajectory.start, default where the end effector starts)")
    if tuple(task.axes) != ("x", "y", "z"):
        raise ScenarioError(f"plant.thrusters = true holds the end effector at a point: task.axes must be "
                            f"['x', 'y', 'z'], got {list(task.axes)}")
    if SOLVERS[solver["method"]] is not CLIKSolver or solver["free_floating"] or solver["alpha"] or solver["enforce_limits"]:
        raise ScenarioError("plant.thrusters = true solves the arm with its own point task (solver.gain [1/s], "
                            "solver.damping): solver.method must be 'clik', without free_floating, alpha or "
                            "enforce_limits (the vehicle is actuated, not free floating)")
    if isinstance(solver["gain"], list) or solver["damping_epsilon"]:
        raise ScenarioError("plant.thrusters = true: solver.gain is one number (K [1/s] of the end-effector point "
                            "task) and solver.damping a fixed DLS damping (no damping_epsilon)")
    if scenario["inequalities"]:
        raise ScenarioError("[[inequalities]] are not enforced on an actuated vehicle yet; remove them or use the "
                            "kinematic plant")
    if plant["motor_feedforward"] or plant["control_dt"]:
        raise ScenarioError("plant.motor_feedforward and plant.control_dt are the GJM controller's; station keeping "
                            "runs its controller once per simulation.dt")


def check_vehicle_control_used(scenario: dict) -> None:
    """A [vehicle_control] key set without plant.thrusters = true is refused (it would do nothing)."""
    if scenario["plant"]["thrusters"]:
        return
    given = changed_keys(scenario, "vehicle_control")
    if given:
        raise ScenarioError(f"vehicle_control.{given[0]} needs plant.thrusters = true (an actuated vehicle); without "
                            f"thrusters the vehicle moves by momentum conservation or as commanded")


def allocation_priorities(value: list, origin: str = "vehicle_control.priorities") -> list[tuple[str, ...]] | None:
    """``[["yaw", "z", "roll", "pitch"], ["x", "y"]]`` -> groups of wrench axes, highest first (None: one group)."""
    if not value:
        return None
    if not all(isinstance(group, list) and group and all(axis in WRENCH_AXES for axis in group) for group in value):
        raise ScenarioError(f"{origin} must be a list of groups of wrench axes among {', '.join(WRENCH_AXES)}, "
                            f"highest priority first, e.g. [['yaw', 'z', 'roll', 'pitch'], ['x', 'y']]; got {value!r}")
    return [tuple(group) for group in value]


def make_actuation(robot: Robot, plant: Plant, task: FrameTask, trajectory, q0: np.ndarray,
                   scenario: dict) -> Actuation:
    """The thrusters of the model and the station-keeping controller of the scenario."""
    check_actuated_scenario(robot, task, scenario)
    try:
        thrusters = thrusters_of(robot)
    except UVMSError as exc:
        raise ScenarioError(f"plant.thrusters = true: {exc}") from None
    control, solver = scenario["vehicle_control"], scenario["solver"]
    try:
        controller = station_keeping(
            plant, thrusters, q0, float(scenario["simulation"]["dt"]), ee_target=trajectory(0.0).pose.translation,
            frame=task.frame, coordination=control["coordination"], knows_current=control["knows_current"],
            kp=np.asarray(control["kp"], dtype=float), ki=np.asarray(control["ki"], dtype=float),
            pose_gains=np.asarray(control["pose_gains"], dtype=float),
            max_speed=np.asarray(control["max_speed"], dtype=float),
            priorities=allocation_priorities(control["priorities"]), arm_feedforward=control["arm_feedforward"],
            ee_gain=float(solver["gain"]), arm_damping=float(solver["damping"]))
    except UVMSError as exc:
        raise ScenarioError(f"vehicle_control: {exc}") from None
    return Actuation(plant, thrusters, controller)


def simulate_actuation(actuation: Actuation, task: FrameTask, trajectory, q0: np.ndarray, duration: float,
                       scenario: dict, progress: bool | None) -> SimulationResult:
    """The run, with the task series (the end effector against the held point) recorded."""
    return simulate(ActuatedPlant(actuation.plant, actuation.thrusters), actuation.controller, q0, duration,
                    float(scenario["simulation"]["dt"]), integrator=scenario["simulation"]["integrator"], task=task,
                    desired=lambda t: trajectory(t).pose, progress=progress)


def actuated_metrics(result: SimulationResult, actuation: Actuation, scenario: dict) -> dict:
    """``metrics.json``'s actuated entries: the thrusters' (:meth:`uvms.sim.result.SimulationResult.actuation_metrics`)
    and what the run was (thruster count, coordination, current)."""
    return {**result.actuation_metrics(), "plant": "hydrodynamic", "thrusters": actuation.thrusters.names,
            "coordination": bool(scenario["vehicle_control"]["coordination"]),
            "current": list(scenario["plant"]["current"]) or [0.0, 0.0, 0.0]}
