"""Collision objectives' cost, as ratios to one ``pin.forwardKinematics`` of the BlueROV2 + Alpha 5 (nv = 11).

Rows, timed interleaved with FK in one run (``timing.interleaved_ratios``; the machine is shared and noisy):

* the signed distances, witness points and distance Jacobians of 10 pairs of shapes of the Alpha 5
  (``PairDistances.evaluate`` + ``jacobian``);
* ``SelfCollision.rows`` with its default pairs (85 after the model's uvms.srdf and the adjacency rule), the
  6 nearest as rows (bounding spheres leave most pairs unqueried);
* a prepared set-based step (``SetBasedSolver.step``: joint limits, the jaws' pose) without collision objectives,
  with ``self_collision`` over the 10 pairs, and with the default pairs; the issue's goal: 10 pairs within 2x
  of the step without.

    python benchmarks/bench_collision.py [--repeat 2000]
"""

from __future__ import annotations

import argparse

import numpy as np
import pinocchio as pin
from timing import interleaved_ratios

import uvms
from uvms.model.collision import collision_geometry
from uvms.model.distances import PairDistances
from uvms.solvers import SetBasedSolver
from uvms.tasks import FrameTask
from uvms.tasks.objectives import JointLimits, SelfCollision

ARM = [3.0, 1.8, 1.8, 1.0, 0.0]  # the work pose of scenarios/bluerov2_alpha5_intervention.toml
DT = 0.02  # [s]
#: Link pairs of the Alpha 5 that make 10 pairs of shapes (the E and C housings have two shapes each).
TEN_PAIRS = [["alpha_m3_inline_link", "alpha_m2_joint_link"], ["alpha_m3_inline_link", "alpha_m1_link"],
             ["alpha_m3_inline_link", "alpha_jaw_link"], ["alpha_m2_joint_link", "alpha_m1_link"],
             ["alpha_m3_inline_link", "alpha_m2_1_2_link"], ["alpha_m2_1_1_link", "alpha_m1_link"],
             ["alpha_m2_1_1_link", "alpha_jaw_link"]]


def ratios(repeat: int) -> dict[str, float]:
    """Label -> median time over one forward kinematics, every call at the same configuration."""
    robot = uvms.load("bluerov2_alpha5")
    q = robot.configuration(base=[0.0, 0.0, -5.0, 0.0, 0.0, 0.0], arm=ARM)
    data = robot.model.createData()
    ten = SelfCollision(robot, min=0.01, band=0.02, pairs=TEN_PAIRS, count=10)
    every = SelfCollision(robot, min=0.01, band=0.02, count=6)
    distances = PairDistances(robot.model, collision_geometry(robot), ten.distances.pairs)
    assert distances.count == 10, distances.count
    target = robot.fk(q) * pin.SE3(np.eye(3), np.array([0.0, 0.05, 0.0]))
    limits = JointLimits(robot, band=0.2)

    def step_of(levels: list):
        solver = SetBasedSolver(robot, [*levels, FrameTask(robot, target=target)], gain=2.0, damping=0.01, dt=DT)
        return lambda: solver.step(uvms.Configuration(robot, q, check=False), DT)

    def ten_distances():
        state = uvms.Configuration(robot, q, check=False)
        found = distances.evaluate(state)
        return distances.jacobian(state, found, np.arange(distances.count))

    calls = {
        f"distances + Jacobians, {distances.count} pairs": ten_distances,
        f"SelfCollision.rows, default pairs ({len(every.links)}), 6 nearest":
            lambda: every.rows(uvms.Configuration(robot, q, check=False)),
        "set-based step, joint limits + pose": step_of([limits]),
        f"set-based step, + self_collision over {distances.count} pairs": step_of([limits, ten]),
        f"set-based step, + self_collision, default pairs ({len(every.links)}), 6 nearest": step_of([limits, every]),
    }
    for call in calls.values():
        call()  # the kernels compiled before timing
    return interleaved_ratios(calls, lambda: pin.forwardKinematics(robot.model, data, q), repeat)[0]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=2000, help="calls of each row over all timing rounds")
    measured = ratios(parser.parse_args().repeat)
    print("| row | ratio to FK |\n|---|---|")
    for label, ratio in measured.items():
        print(f"| {label} | {ratio:.0f}x |")
    without = measured["set-based step, joint limits + pose"]
    with_ten = next(value for label, value in measured.items() if "over 10 pairs" in label)
    print(f"\n10 pairs cost {with_ten / without:.2f}x the step without collision objectives (goal <= 2x)")


if __name__ == "__main__":
    main()
