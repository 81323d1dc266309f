"""Whole-body MPC (uvms.control.mpc, Crocoddyl Box-FDDP) on the intervention: solve time per control step and the
end effector's error on the measured state, beside the set-based chain on the same scenario.

The scenario ``bluerov2_alpha5_intervention`` (BlueROV2 + Alpha 5, 8 thrusters with their 0.1 s lag, the jaws along
0.3 m of a panel in 10 s, a 0.3 m/s current from ahead) is built once; the set-based chain runs as ``uvms run`` runs
it, and the MPC drives the same ActuatedPlant (same plant, thrusters, trajectory, initial state, RK4 at 0.01 s),
solving every ``control_period`` from the measured state. Each MPC configuration: median and p99 solve time per
control step [ms], iterations, max/RMS end-effector error [cm], max tilt [rad], max |thrust| / limit. Needs the
``mpc`` extra (Crocoddyl).

    python benchmarks/bench_mpc.py [--duration 10] [--quick]

Measured (2026-12-06, this 2-core machine shared, load ~5; pin 4.0.0, crocoddyl 3.2.1), 10 s:
set-based chain: max 1.956 cm, RMS 0.539 cm, tilt 0.0199 rad;
MPC N=10 x 0.1 s, 1 it, 20 Hz: max 0.887 cm, RMS 0.163 cm, tilt 0.0078 rad, solve median 7.8 ms, p99 11.7 ms;
N=20 x 0.05 s: max 0.546 cm, RMS 0.087 cm, median 15.2 ms, p99 19.3 ms; N=10 x 0.1 s, current known: max 0.425 cm;
N=10 x 0.1 s at 100 Hz: max 0.604 cm, median 7.8 ms, p99 14.7 ms. Thrusts within bounds (max 0.18 of the limit).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from uvms.control.mpc.controller import MPCController
from uvms.control.mpc.settings import MPCSettings
from uvms.dynamics.plant.actuated import ActuatedPlant
from uvms.dynamics.plant.command import State
from uvms.scenario.build import build
from uvms.scenario.inequalities import vehicle_tilt
from uvms.scenario.schema import read_scenario
from uvms.sim import simulate

SCENARIO = Path(__file__).resolve().parent.parent / "scenarios" / "bluerov2_alpha5_intervention.toml"

#: (label, settings): horizon >= 1 s each; the current unknown unless said.
CONFIGURATIONS = [
    ("N=10 x 0.1 s, 1 it, 20 Hz", MPCSettings(horizon=10, node_dt=0.1, iterations=1, control_period=0.05)),
    ("N=20 x 0.05 s, 1 it, 20 Hz", MPCSettings(horizon=20, node_dt=0.05, iterations=1, control_period=0.05)),
    ("N=10 x 0.1 s, 1 it, 20 Hz, current known", MPCSettings(horizon=10, node_dt=0.1, iterations=1,
                                                             control_period=0.05, knows_current=True)),
    ("N=10 x 0.1 s, 1 it, 100 Hz", MPCSettings(horizon=10, node_dt=0.1, iterations=1, control_period=0.01)),
]


def summary(result, thrusters) -> dict[str, float]:
    """The run's end-effector error [cm], tilt [rad] and thrust ratio."""
    errors = result.position_error
    limits = np.where(result.actuation.thrusts >= 0, thrusters.upper, -thrusters.lower)
    return {"max_cm": 100 * float(errors.max()), "rms_cm": 100 * float(np.sqrt(np.mean(errors ** 2))),
            "tilt": float(vehicle_tilt(result.vehicle_pose()).max()),
            "thrust_ratio": float(np.max(np.abs(result.actuation.thrusts) / limits))}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=10.0, help="[s] of the 10 s scenario")
    parser.add_argument("--quick", action="store_true", help="the first configuration only")
    args = parser.parse_args()
    scenario = read_scenario(SCENARIO, [f"trajectory.duration={10.0}"])
    setup = build(scenario)
    thrusters, trajectory, dt = setup.actuation.thrusters, setup.trajectory, float(scenario["simulation"]["dt"])
    desired = lambda t: trajectory(t).pose  # noqa: E731
    plant = ActuatedPlant(setup.plant, thrusters)
    started = time.perf_counter()
    chain = simulate(plant, setup.controller, setup.q0, args.duration, dt, task=setup.task, desired=desired,
                     progress=False)
    rows = [("set-based chain (iCAT + vehicle loop)", summary(chain, thrusters),
             {"step_ms": 1e3 * (time.perf_counter() - started) / round(args.duration / dt)})]
    floor = -5.55 + 0.5  # the scenario's seabed clearance: the vehicle's origin 0.5 m above z = -5.55 m
    for label, settings in CONFIGURATIONS[:1] if args.quick else CONFIGURATIONS:
        mpc = MPCController(setup.plant, thrusters, lambda t: trajectory(t).pose.translation, frame=setup.task.frame,
                            settings=settings, floor=floor)
        mpc.reset(State(setup.q0))
        mpc.command(State(setup.q0, np.zeros(setup.robot.nv)), 0.0)  # numba compiles/loads the derivative kernel
        mpc.reset(State(setup.q0))
        result = simulate(plant, mpc, setup.q0, args.duration, dt, task=setup.task, desired=desired,
                          progress=False)
        times = 1e3 * np.array(mpc.solve_times)
        rows.append((label, summary(result, thrusters), {
            "median_ms": float(np.median(times)), "p99_ms": float(np.percentile(times, 99)),
            "iterations": float(np.mean(mpc.iterations)), "solves": len(times),
            "min_z": float(result.vehicle_pose()[:, 2].min())}))
    print(f"{SCENARIO.name}, {args.duration:g} s, dt {dt:g} s, current {scenario['plant']['current']} m/s")
    print(f"{'controller':44s} {'max err':>8s} {'rms err':>8s} {'tilt':>7s} {'|f|/lim':>7s}  solve per step")
    for label, numbers, timing in rows:
        extra = ", ".join(f"{key} {value:.4g}" for key, value in timing.items())
        print(f"{label:44s} {numbers['max_cm']:6.3f}cm {numbers['rms_cm']:6.3f}cm {numbers['tilt']:7.4f} "
              f"{numbers['thrust_ratio']:7.3f}  {extra}")


if __name__ == "__main__":
    main()
