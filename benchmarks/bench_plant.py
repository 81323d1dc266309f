"""The hydrodynamic plant's equations of motion per evaluation, as ratios to one ``pin.aba`` on the same model.

``Plant._mass_and_bias`` (Mbar = M + sum J^T M_A J and nbar = h - sum J^T f, every term on: added mass, damping,
a 0.3 m/s current, buoyancy; then with a thrusters' wrench too) and ``Plant.dynamics`` (with the wrench, then the
vehicle's accelerations and the motors' torques: what an RK4 stage calls) on the BlueROV2 + Alpha 5 (7 hydrodynamic
links, nv = 11), the RexROV-sized fixture (tests/fixtures/rexrov_like: one hull link, a 4-DOF arm and a mimic gripper,
nv = 11) and amundsen2018's snake (9 links, nv = 14), beside Pinocchio's own ``aba``, ``crba`` and
``crba`` + ``nonLinearEffects``, each timed back to back with the reference in every round (benchmarks/timing.py).
``pin.aba`` refuses mimic joints: on the fixture it runs on the same model with its mimic finger locked (the same
bodies and nv).

    python benchmarks/bench_plant.py [--repeat 2000]
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

import numpy as np
import pinocchio as pin
from timing import interleaved_ratios

import uvms

FIXTURE = Path(__file__).resolve().parents[1] / "tests" / "fixtures" / "rexrov_like" / "rexrov_like.urdf"
MODELS = {"bluerov2_alpha5": ("bluerov2_alpha5", {}), "rexrov_like (fixture)": (str(FIXTURE), {"ee": "tool"}),
          "amundsen2018": ("amundsen2018", {})}


def reference_model(robot: uvms.Robot) -> pin.Model:
    """The model ``pin.aba`` runs on: the robot's own, or with its mimic joints locked (aba refuses them)."""
    if not robot.mimic_joint_names:
        return robot.model
    locked = [robot.model.getJointId(name) for name in robot.mimic_joint_names]
    return pin.buildReducedModel(robot.model, locked, robot.neutral())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=2000)
    repeat = parser.parse_args().repeat
    print(f"load average {' '.join(f'{x:.2f}' for x in os.getloadavg())} (1, 5, 15 min), {os.cpu_count()} cores")
    rng = np.random.default_rng(0)
    for label, (source, options) in MODELS.items():
        robot = uvms.load(source, **options)
        plant = uvms.Plant(robot, gravity=True, current=[0.3, 0.0, 0.0])
        model, data = robot.model, robot.model.createData()
        q = pin.integrate(model, robot.neutral(), 0.3 * rng.normal(size=robot.nv))
        v, wrench = 0.3 * rng.normal(size=robot.nv), rng.normal(size=6)
        command = 0.3 * rng.normal(size=plant.n_arm)
        reference = reference_model(robot)
        reference_data = reference.createData()
        q_ref = pin.integrate(reference, pin.neutral(reference), 0.3 * rng.normal(size=reference.nv))
        v_ref, zero = 0.3 * rng.normal(size=reference.nv), np.zeros(reference.nv)
        plant.dynamics(q, v, command, wrench)  # numba loads its kernel once
        calls = {
            "plant Mbar, nbar (_mass_and_bias)": lambda: plant._mass_and_bias(q, v),
            "plant Mbar, nbar + thrusters' wrench": lambda: plant._mass_and_bias(q, v, wrench),
            "plant dynamics (+ base solve, torques)": lambda: plant.dynamics(q, v, command, wrench),
            "pin.crba": lambda: pin.crba(model, data, q),
            "pin.crba + pin.nonLinearEffects": lambda: (pin.crba(model, data, q),
                                                        pin.nonLinearEffects(model, data, q, v)),
        }
        ratios, seconds = interleaved_ratios(
            calls, lambda: pin.aba(reference, reference_data, q_ref, v_ref, zero), repeat)
        ratios.pop("pin.forwardKinematics")  # timing.py's name for its reference: here pin.aba
        print(f"{label}: nv {robot.nv}, {len(plant.links)} hydrodynamic links; one pin.aba = {1e6 * seconds:.2f} us"
              + (f" (the mimic finger locked, nv {reference.nv})" if reference is not robot.model else ""))
        for name, ratio in {"pin.aba": 1.0, **ratios}.items():
            print(f"  {name:<44} {ratio:8.1f} x aba")
    print(f"load average {' '.join(f'{x:.2f}' for x in os.getloadavg())} (1, 5, 15 min) at the end")


if __name__ == "__main__":
    main()
