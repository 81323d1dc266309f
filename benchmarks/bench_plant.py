"""The hydrodynamic plant's equations of motion per evaluation, as ratios to one ``pin.aba`` on the same model.

``Plant._mass_and_bias`` (Mbar = M + sum J^T M_A J and nbar = h - sum J^T f, every term on: added mass, damping,
a 0.3 m/s current, buoyancy, a thrusters' wrench) on the BlueROV2 + Alpha 5 (7 hydrodynamic links, nv = 11) and
amundsen2018's snake (9 links, nv = 14), beside Pinocchio's own ``aba``, ``crba`` + ``nonLinearEffects`` and
``forwardKinematics``, each timed back to back with the reference in every round (benchmarks/timing.py).

    python benchmarks/bench_plant.py [--repeat 2000]
"""

from __future__ import annotations

import argparse

import numpy as np
import pinocchio as pin
from timing import interleaved_ratios

import uvms


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=2000)
    repeat = parser.parse_args().repeat
    rng = np.random.default_rng(0)
    for name in ("bluerov2_alpha5", "amundsen2018"):
        robot = uvms.load(name)
        plant = uvms.Plant(robot, gravity=True, current=[0.3, 0.0, 0.0])
        model, data = robot.model, robot.model.createData()
        q = pin.integrate(model, robot.neutral(), 0.3 * rng.normal(size=robot.nv))
        v, wrench, zero = 0.3 * rng.normal(size=robot.nv), rng.normal(size=6), np.zeros(robot.nv)
        plant._mass_and_bias(q, v, wrench)  # numba loads its kernel once
        calls = {
            "plant Mbar, nbar": lambda: plant._mass_and_bias(q, v, wrench),
            "pin.crba + pin.nonLinearEffects": lambda: (pin.crba(model, data, q),
                                                        pin.nonLinearEffects(model, data, q, v)),
            "pin.forwardKinematics (position, velocity)": lambda: pin.forwardKinematics(model, data, q, v),
        }
        ratios, reference = interleaved_ratios(calls, lambda: pin.aba(model, data, q, v, zero), repeat)
        print(f"{name} (nv {robot.nv}, {len(plant.links)} hydrodynamic links); one pin.aba = {1e6 * reference:.2f} us")
        ratios.pop("pin.forwardKinematics")  # timing.py's name for its reference: here pin.aba
        for label, ratio in {"pin.aba": 1.0, **ratios}.items():
            print(f"  {label:<44} {ratio:8.1f} x aba")


if __name__ == "__main__":
    main()
