"""Thrust allocation per call, as ratios to one ``pin.forwardKinematics`` on the BlueROV2 + Alpha 5.

The BlueROV2 Heavy's 8 thrusters (``models/bluerov2_alpha5/thrusters.yaml``), ``uvms.dynamics.ThrustAllocator``:

* attainable: random wrenches B f with f inside 0.3 x the bounds (B^+ tau inside the bounds: no solver runs);
* bounded: random wrenches ~ N(0, [250 N x3, 40 N m x3]) beyond the thrusters (bounded least squares by
  scipy's lsq_linear/BVLS, then the least-norm thrusts by DAQP);
* bounded, two priority groups (heading, depth, attitude before surge and sway; one more DAQP stage);
* for comparison: scipy.optimize.lsq_linear (BVLS and TRF) alone on the same unattainable wrenches, and
  numpy's pinv(B) @ tau (the pseudo-inverse recomputed per call).

Ratios are medians over ``--repeat`` interleaved rounds (this machine is shared and noisy; absolute times are
not comparable between runs).

    python benchmarks/bench_allocation.py [--repeat 200]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
import pinocchio as pin
from scipy.optimize import lsq_linear

import uvms


def per_call(function, arguments, number: int) -> float:
    """Mean time [s] of one call over ``number`` calls cycling through ``arguments``."""
    started = time.perf_counter()
    for index in range(number):
        function(arguments[index % len(arguments)])
    return (time.perf_counter() - started) / number


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=200, help="interleaved rounds (median)")
    parser.add_argument("--number", type=int, default=20, help="calls per measure in a round")
    options = parser.parse_args()
    robot = uvms.load("bluerov2_alpha5")
    thrusters = uvms.dynamics.thrusters_of(robot)
    matrix = uvms.dynamics.allocation_matrix(robot, thrusters)
    lower, upper = thrusters.lower, thrusters.upper
    plain = uvms.dynamics.ThrustAllocator(matrix, lower, upper)
    ranked = uvms.dynamics.ThrustAllocator(matrix, lower, upper, priorities=[("yaw", "z", "roll", "pitch"), ("x", "y")])
    rng = np.random.default_rng(0)
    attainable = [matrix @ rng.uniform(0.3 * lower, 0.3 * upper) for _ in range(50)]
    unattainable = [rng.normal(size=6) * np.array([250, 250, 250, 40, 40, 40]) for _ in range(50)]
    assert all(plain.allocate(w).solver == "pinv" for w in attainable)
    assert not any(plain.allocate(w).attainable for w in unattainable)
    model, data, q = robot.model, robot.model.createData(), robot.neutral()
    cases = {
        "allocate, attainable (pinv, no solver)": (plain.allocate, attainable),
        "allocate, unattainable (BVLS + DAQP least norm)": (plain.allocate, unattainable),
        "allocate, unattainable, 2 priority groups (+ DAQP)": (ranked.allocate, unattainable),
        "scipy lsq_linear BVLS alone": (lambda w: lsq_linear(matrix, w, bounds=(lower, upper), method="bvls"),
                                        unattainable),
        "scipy lsq_linear TRF alone": (lambda w: lsq_linear(matrix, w, bounds=(lower, upper), method="trf"),
                                       unattainable),
        "numpy pinv(B) @ tau per call": (lambda w: np.linalg.pinv(matrix) @ w, attainable),
    }
    ratios: dict[str, list[float]] = {name: [] for name in cases}
    references = []
    for _ in range(options.repeat):
        reference = per_call(lambda _: pin.forwardKinematics(model, data, q), [None], 10 * options.number)
        references.append(reference)
        for name, (function, arguments) in cases.items():
            ratios[name].append(per_call(function, arguments, options.number) / reference)
    print(f"BlueROV2 Heavy, 8 thrusters; pin.forwardKinematics = {statistics.median(references) * 1e6:.2f} us "
          f"in this run (median of {options.repeat} rounds)\n")
    print("| call | time / pin.forwardKinematics |\n|---|---|")
    for name, values in ratios.items():
        print(f"| {name} | {statistics.median(values):.1f} |")


if __name__ == "__main__":
    main()
