"""Workspace sampling speed: batched FK vs a Python loop over Pinocchio FK vs roboticstoolbox's batched fkine.

One arm of xiang2019 (4 revolute joints, modified D-H), samples per second measured in one run.

    pip install -e ".[bench]"
    python benchmarks/bench_workspace.py [--samples 200000]

Goals (issue 5): >= 5x the Pinocchio loop, >= 10x roboticstoolbox. Issue 16: `monte_carlo` of one million
samples of both arms (volumes) <= 1 s, with dexterity <= 3 s.

The dexterity per voxel needs the frame's orientation too: its rows time the approach and roll
axes carried with the point (`positions_and_axes`) against full rotation matrices (`poses`), each
followed by the orientation binning, and a whole `monte_carlo(..., dexterity=True)` run.
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np
import pinocchio as pin

import uvms
from uvms.workspace import BatchKinematics, OrientationGrid, monte_carlo


def rate(function, count: int) -> float:
    """Samples per second of one call that handles ``count`` samples (best of 3)."""
    best = min(timed(function) for _ in range(3))
    return count / best


def timed(function) -> float:
    started = time.perf_counter()
    function()
    return time.perf_counter() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=200_000)
    options = parser.parse_args()
    robot = uvms.load("xiang2019")
    batch = BatchKinematics(robot, "left_ee")
    values = batch.sample(options.samples, 0)
    rows = [("uvms BatchKinematics.positions", rate(lambda: batch.positions(values), len(values)))]
    grid = OrientationGrid()
    rows.append(("uvms positions_and_axes + orientation cells (dexterity)",
                 rate(lambda: grid.cells_from_axes(batch.positions_and_axes(values, grid.axes)[1]), len(values))))
    rows.append(("uvms poses + orientation cells (dexterity)",
                 rate(lambda: grid.cells(batch.poses(values)[0]), len(values))))
    model, data = robot.model, robot.data
    frame = robot.frame_id("left_ee")
    names = robot.arm_joint_names
    columns = [robot.nq_vehicle + names.index(name) for name in batch.joint_names]
    loop_count = min(len(values), 20_000)
    q = robot.neutral()

    def pinocchio_loop():
        for sample in values[:loop_count]:
            q[columns] = sample
            pin.framesForwardKinematics(model, data, q)
            data.oMf[frame].translation.copy()

    rows.append(("Python loop of pin.framesForwardKinematics", rate(pinocchio_loop, loop_count)))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            import roboticstoolbox as rtb
            from spatialmath import SE3
        links = [rtb.RevoluteMDH(a=a, alpha=alpha) for a, alpha in ((0, 0), (0.08, -np.pi / 2), (0.37, 0), (0.22, 0))]
        arm = rtb.DHRobot(links, tool=SE3.Tx(0.308), name="xiang2019_left")
        rows.append(("roboticstoolbox DHRobot.fkine (batched)", rate(lambda: arm.fkine(values), len(values))))
    except ImportError:
        print("roboticstoolbox not installed: pip install -e '.[bench]'")
    right = BatchKinematics(robot, "right_ee")
    million = batch.sample(1_000_000, 1)
    seconds = timed(lambda: (batch.positions(million), right.positions(million)))
    reference = rows[0][1]
    print("| implementation | samples/s | uvms speed-up |\n|---|---|---|")
    for label, samples_per_second in rows:
        print(f"| {label} | {samples_per_second:,.0f} | {reference / samples_per_second:.1f}x |")
    print(f"\nOne million samples of both arms: {seconds:.2f} s")
    for dexterity, hull in ((False, False), (True, False), (False, True), (True, True)):
        started = time.perf_counter()
        monte_carlo(robot, ["left_ee", "right_ee"], 1_000_000, dexterity=dexterity, remove_hull=hull, progress=False)
        seconds = time.perf_counter() - started
        extras = "".join([" + dexterity" if dexterity else "", " + hull removal" if hull else ""])
        print(f"monte_carlo, both arms, 1M samples each, volumes{extras}: {seconds:.2f} s")


if __name__ == "__main__":
    main()
