"""Whole-body MPC (uvms.control.mpc: CSQP on Crocoddyl, the scenario's objectives as constraints) on the actuated
BlueROV2 + Alpha 5: solve time per control step and the goals of issue 49, measured on the recorded states.

Each case is a shipped scenario on the actuated plant (``plant.type = "hydrodynamic"``, thrusters with their 0.1 s
lag, gravity and buoyancy, RK4 at 0.01 s), the MPC given the scenario's ``[[inequalities]]`` as its constraints and
the current unknown to it (a wrench estimate from the mismatch). The distances, tilt and clearance are recomputed
from the recorded configurations with the objectives themselves (coal for the distances). The timing rows give the
median and p99 solve time per control step [ms], the mean iterations, and their ratio to one ``pin.aba`` on the same
model measured in the same run. Needs the ``mpc`` extra (Crocoddyl, mim-solvers).

    python benchmarks/bench_mpc.py [--quick]

Measured (2026-12-06, this 2-core machine shared by five, pin 4.0.0, crocoddyl 3.2.1, mim-solvers 0.3.0): see the
MPC section of benchmarks/README.md.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

import numpy as np
import pinocchio as pin

from uvms.control.mpc.controller import MPCController
from uvms.control.mpc.settings import MPCSettings
from uvms.dynamics.plant.actuated import ActuatedPlant
from uvms.dynamics.plant.command import State
from uvms.dynamics.plant.plant import Plant
from uvms.robot.configuration import Configuration
from uvms.scenario.build import build
from uvms.scenario.inequalities import vehicle_tilt
from uvms.scenario.schema import read_scenario
from uvms.sim import simulate
from uvms.tasks.objectives.frames import VehicleAttitude

SCENARIOS = Path(__file__).resolve().parent.parent / "scenarios"
ACTUATED = ["plant.type=hydrodynamic", "plant.thrusters=true", "plant.gravity=true", "simulation.dt=0.01",
            "simulation.integrator=rk4"]
CURRENT = "plant.current=[-0.3,0.0,0.0]"
MOVING = ["trajectory.end_offset=[0.0,0.45,0.0]", "trajectory.law=quintic", "trajectory.duration=6.0",
          "simulation.duration=7.0"]

#: (label, scenario, overrides): the goal cases.
CASES = [
    ("intervention (0.3 m/s)", "bluerov2_alpha5_intervention", []),
    ("pipe, still water", "bluerov2_alpha5_pipe", []),
    ("pipe, 0.3 m/s", "bluerov2_alpha5_pipe", [CURRENT]),
    ("stow, still water", "bluerov2_alpha5_stow", []),
    ("stow, 0.3 m/s", "bluerov2_alpha5_stow", [CURRENT]),
    ("moving task 0.45 m/6 s, tilt <= 3 deg", "bluerov2_alpha5_intervention", MOVING),
    ("saturated current (1.0 m/s)", "bluerov2_alpha5_intervention_saturated_current", []),
]
BASE = MPCSettings(horizon=10, node_dt=0.1)
#: (label, settings) of the timing rows (the intervention).
TIMINGS = [
    ("N=10 x 0.1 s, CSQP 1 it", BASE),
    ("N=20 x 0.05 s, CSQP 1 it", MPCSettings(horizon=20, node_dt=0.05)),
    ("N=10 x 0.1 s, Box-FDDP 1 it (penalties)", MPCSettings(horizon=10, node_dt=0.1, solver="box_fddp")),
]


def scaled_added_mass(plant: Plant, factor: float) -> Plant:
    """The same plant with every link's added mass times ``factor`` (a model mismatch)."""
    hydro = plant.hydro
    links = {name: dataclasses.replace(link, added_mass=link.added_mass * factor) for name, link in hydro.links.items()}
    return Plant(plant.robot, dataclasses.replace(hydro, links=links), gravity=plant.gravity,
                 motor_time_constant=plant.motor_time_constant, added_mass=plant.added_mass, damping=plant.damping)


def run(name: str, overrides: list[str], settings: MPCSettings, *, moving: bool = False, added_mass: float = 1.0):
    scenario = read_scenario(SCENARIOS / f"{name}.toml", [*ACTUATED, *overrides])
    setup = build(scenario)
    objectives = setup.inequalities.objectives
    if moving:  # tilt <= 3 degrees
        objectives = [VehicleAttitude(setup.robot, np.radians(3.0), name="vehicle_attitude")
                      if item.type_name == "vehicle_attitude" else item for item in objectives]
    trajectory, thrusters = setup.trajectory, setup.actuation.thrusters
    model = setup.plant if added_mass == 1.0 else scaled_added_mass(setup.plant, added_mass)
    mpc = MPCController(model, thrusters, lambda t: trajectory(t).pose.translation, frame=setup.task.frame,
                        settings=settings, constraints=objectives)
    mpc.reset(State(setup.q0))
    mpc.command(State(setup.q0, np.zeros(setup.robot.nv)), 0.0)  # numba compiles/loads the derivative kernel
    mpc.reset(State(setup.q0))
    duration = float(scenario.simulation.duration or setup.duration)
    result = simulate(ActuatedPlant(setup.plant, thrusters), mpc, setup.q0, duration, 0.01, task=setup.task,
                      desired=lambda t: trajectory(t).pose, progress=False)
    state = Configuration(setup.robot, setup.q0)
    margins = {item.name: np.inf for item in objectives}
    lowest = {item.name: np.inf for item in objectives}
    for q in result.q:
        state.update(q)
        for item in objectives:
            value = item.value(state)
            margins[item.name] = min(margins[item.name], float(np.min(np.minimum(value - item.lower,
                                                                                   item.upper - value))))
            lowest[item.name] = min(lowest[item.name], float(np.min(value)))
    limits = np.where(result.actuation.thrusts >= 0, thrusters.upper, -thrusters.lower)
    times = 1e3 * np.array(mpc.solve_times)
    return {"max_cm": 100 * float(result.position_error.max()),
            "tilt": float(vehicle_tilt(result.vehicle_pose()).max()),
            "thrust_ratio": float(np.max(np.abs(result.actuation.thrusts) / limits)), "margins": margins,
            "lowest": lowest, "median_ms": float(np.median(times)), "p99_ms": float(np.percentile(times, 99)),
            "iterations": float(np.mean(mpc.iterations)), "robot": setup.robot, "q0": setup.q0}


def aba_us(robot, q0: np.ndarray) -> float:
    """One pin.aba on the robot's model [us] (median of 2000)."""
    model, data = robot.model, robot.model.createData()
    v, tau = np.zeros(model.nv), np.zeros(model.nv)
    samples = []
    for _ in range(2000):
        started = time.perf_counter()
        pin.aba(model, data, q0, v, tau)
        samples.append(time.perf_counter() - started)
    return 1e6 * float(np.median(samples))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="the timing rows only")
    args = parser.parse_args()
    print(f"{'timing (intervention, 10 s)':44s} {'median':>8s} {'p99':>8s} {'iters':>6s} {'max err':>8s}  "
          f"ratio to pin.aba")
    for label, settings in TIMINGS:
        numbers = run("bluerov2_alpha5_intervention", [], settings)
        aba = aba_us(numbers["robot"], numbers["q0"])
        print(f"{label:44s} {numbers['median_ms']:6.2f}ms {numbers['p99_ms']:6.2f}ms {numbers['iterations']:6.2f} "
              f"{numbers['max_cm']:6.3f}cm  median {1e3 * numbers['median_ms'] / aba:.0f} x aba ({aba:.1f} us)")
    if args.quick:
        return
    print(f"\n{'case (N=10 x 0.1 s, CSQP, current unknown)':44s} {'max err':>8s} {'tilt':>7s} {'|f|/lim':>7s}  "
          f"smallest value / margin to the valid set per objective")
    cases = [(label, name, overrides, 1.0) for label, name, overrides in CASES]
    cases += [(f"intervention, prediction's added mass x{factor}", "bluerov2_alpha5_intervention", [], factor)
              for factor in (0.8, 1.2)]
    for label, name, overrides, factor in cases:
        numbers = run(name, overrides, BASE, moving=overrides is MOVING, added_mass=factor)
        rows = ", ".join(f"{key} {numbers['lowest'][key]:.4f}/{numbers['margins'][key]:+.4f}"
                         for key in numbers["margins"])
        print(f"{label:44s} {numbers['max_cm']:6.3f}cm {numbers['tilt']:7.4f} {numbers['thrust_ratio']:7.3f}  {rows}"
              f"  (solve {numbers['median_ms']:.1f}/{numbers['p99_ms']:.1f} ms)")


if __name__ == "__main__":
    main()
