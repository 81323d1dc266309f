"""Cost of the uvms kinematics calls, as ratios to one ``pin.forwardKinematics`` on the same model.

The machine is shared and noisy, so absolute times are not comparable between
runs; ratios measured side by side in one run are. Run:

    python benchmarks/bench_kinematics.py [--repeat 2000]

and it prints a Markdown table (the README quotes one).
"""

from __future__ import annotations

import argparse
import timeit

import numpy as np
import pinocchio as pin

import uvms


def best_time(function, repeat: int) -> float:
    """Best-of-5 mean time of one call [s]."""
    return min(timeit.repeat(function, number=repeat, repeat=5)) / repeat


def measure(name: str, robot: uvms.Robot, repeat: int) -> dict[str, float]:
    """Times of the kinematics calls on one model, relative to pin.forwardKinematics."""
    q = robot.random_configuration(0)
    model, data = robot.model, robot.data
    frame = robot.frame_id()
    reference = best_time(lambda: pin.forwardKinematics(model, data, q), repeat)
    calls = {
        "pin.computeFrameJacobian": lambda: pin.computeFrameJacobian(model, data, q, frame, pin.LOCAL_WORLD_ALIGNED),
        "Robot.fk": lambda: robot.fk(q),
        "Robot.jacobian": lambda: robot.jacobian(q),
        "Robot.generalized_jacobian": lambda: robot.generalized_jacobian(q),
    }
    ratios = {"model": name, "nv": robot.nv, "pin.forwardKinematics [us]": reference * 1e6}
    for label, call in calls.items():
        ratios[label] = best_time(call, repeat) / reference
    return ratios


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=2000, help="calls per timing")
    options = parser.parse_args()
    rows = [measure(name, uvms.load(name), options.repeat) for name in ("bluerov2_alpha5", "amundsen2018", "xiang2019")]
    rows.append(measure("bluerov2+panda", uvms.model.mount_arm(uvms.load("bluerov2_alpha5"), "panda",
                                                         placement=[0.0, 0.0, -0.2, np.pi, 0.0, 0.0]), options.repeat))
    headers = list(rows[0])
    print("| " + " | ".join(headers) + " |")
    print("|" + "---|" * len(headers))
    for row in rows:
        cells = [f"{row[h]:.2f}" if isinstance(row[h], float) else str(row[h]) for h in headers]
        print("| " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
