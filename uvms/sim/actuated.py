"""The front-end of the one loop (:func:`uvms.sim.simulate.run_loop`) for a plant whose vehicle has thrusters.

Same loop, same integrators as every run: the system is :class:`uvms.dynamics.actuated.ActuatedPlantSystem`
(state q and x = [v, thrusts]). The result is the one :class:`uvms.sim.result.SimulationResult` with the plant
series; the series it has no field for (thrusts, thrust_command, body_wrench, the powers and the controller's
own) are in ``result.actuation`` (name -> (N, ...) array).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import fields

import numpy as np

from ..dynamics.actuated import ActuatedController, ActuatedPlantSystem, ThrusterDynamics
from ..dynamics.plant import Plant
from ..dynamics.thrusters import Thrusters
from ..errors import ConfigurationError
from ..numerics.integrate import check_integrator, step_count
from .result import SimulationResult
from .simulate import Recorder, run_loop

__all__ = ["actuation_metrics", "simulate_actuated"]


def simulate_actuated(
    plant: Plant,
    thrusters: Thrusters | ThrusterDynamics,
    controller: ActuatedController,
    q0: np.ndarray,
    duration: float,
    dt: float,
    *,
    v0: np.ndarray | None = None,
    thrusts0: np.ndarray | None = None,
    integrator: str = "rk4",
    recorders: Sequence[Recorder] = (),
    progress: bool | None = None,
) -> SimulationResult:
    """Integrate the plant with thrusters under a digital controller (called once per step of ``dt``).

    Args:
        plant: the Plant (its current, damping, gravity); thrusters: the vehicle's thrusters.
        controller: (t, q, v, f) -> ActuatedCommand (e.g. :class:`uvms.control.station_keeping.StationKeeping`).
        q0: (nq,); v0: (nv,) (None: rest); thrusts0: (n,) [N] (None: zero).
        duration, dt: [s]; integrator: "rk4" or "euler".
        recorders: more series per row, (t, q, x, sample) -> {name: value}.

    Returns:
        SimulationResult with the plant series and ``actuation`` (the thrusters' and controller's series).

    Raises:
        ConfigurationError: bad q0, v0 or thrusts0 (thrusts outside the bounds included).
        UVMSError: bad dt or duration, a controller returning the wrong sizes, a non-finite state.
    """
    integrator = check_integrator(integrator)
    steps = step_count(duration, dt)
    dynamics = thrusters if isinstance(thrusters, ThrusterDynamics) else ThrusterDynamics(plant, thrusters)
    robot = plant.robot
    q = robot.check_configuration(q0).copy()
    v = np.zeros(plant.model.nv) if v0 is None else robot.check_velocity(v0).copy()
    f = np.zeros(dynamics.n) if thrusts0 is None else robot.check_velocity(thrusts0, dynamics.n, "thrusts0").copy()
    if np.any(f < dynamics.lower) or np.any(f > dynamics.upper):
        raise ConfigurationError(f"thrusts0 {f.tolist()} must lie within [{dynamics.lower.tolist()}, "
                                 f"{dynamics.upper.tolist()}] N")
    system = ActuatedPlantSystem(plant, dynamics, controller)
    arrays, wall_time = run_loop(system, q, np.concatenate([v, f]), steps=steps, dt=dt, integrator=integrator,
                                 recorders=recorders, progress=progress, desc="actuated plant")
    known = {field.name for field in fields(SimulationResult)}
    return SimulationResult(**{k: a for k, a in arrays.items() if k in known}, robot=robot, plant=plant, dt=dt,
                            integrator=integrator, wall_time=wall_time, controller=controller,
                            actuation={k: a for k, a in arrays.items() if k not in known}, thruster_dynamics=dynamics)


def actuation_metrics(result: SimulationResult) -> dict:
    """Numbers of an actuated run for ``metrics.json`` [SI units].

    max_thrust_ratio: max over time and thrusters of |f_i| / (its limit in that direction), <= 1;
    saturated_time_fraction: fraction of rows with a thrust command at a bound;
    thrust_work: integral of the thrust power B f . nu [J] (signed: negative when the current pushes the
    vehicle back against its thrust); thruster_energy: integral of sum_i |f_i (B_i . nu)| [J], the mechanical
    power each thruster gives the hull, counted positive either way (not the electrical energy: no propeller
    efficiency model); both by the trapezoid rule. With a controller that records ``vehicle_position_error``
    (:class:`uvms.control.station_keeping.StationKeeping`): vehicle_position_error (its max over the run) and
    final_vehicle_position_error [m].
    """
    dynamics: ThrusterDynamics = result.thruster_dynamics
    thrusts, commands = result.actuation["thrusts"], result.actuation["thrust_command"]
    limits = np.where(thrusts >= 0, dynamics.upper, np.where(dynamics.lower < 0, -dynamics.lower, np.inf))
    at_bound = np.isclose(commands, dynamics.upper) | np.isclose(commands, dynamics.lower) & (dynamics.lower < 0)
    metrics = {"max_thrust_ratio": float(np.max(np.abs(thrusts) / limits)),
               "saturated_time_fraction": float(np.mean(np.any(at_bound, axis=1))),
               "thrust_work": _trapezoid(result.actuation["thrust_power"], result.t),
               "thruster_energy": _trapezoid(result.actuation["thruster_power_abs"], result.t)}
    if "vehicle_position_error" in result.actuation:
        error = result.actuation["vehicle_position_error"]
        metrics.update(vehicle_position_error=float(np.max(error)), final_vehicle_position_error=float(error[-1]))
    return metrics


def _trapezoid(values: np.ndarray, t: np.ndarray) -> float:
    return float(np.sum(0.5 * (values[1:] + values[:-1]) * np.diff(t)))
