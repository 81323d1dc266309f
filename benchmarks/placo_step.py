"""One placo kinematics step on a URDF, as a ratio to pin.forwardKinematics in placo's own environment.

placo pins an older Pinocchio than uvms (placo 0.10.2 installs pin 3.8.0), so it runs apart; ``bench_clik.py``
and ``bench_speed.py`` call this script with that environment's Python and print its ratio beside uvms's::

    python -m venv /tmp/placo_env && /tmp/placo_env/bin/pip install placo
    UVMS_PLACO_PYTHON=/tmp/placo_env/bin/python python benchmarks/bench_speed.py

The step is the one placo users write: a ``KinematicsSolver`` on the URDF with placo's floating base (6 + n),
one pose task (``add_frame_task``, position and orientation) on the given frame, joint limits on, and
``solve(True)`` (the QP and the integration of q). The ratio is to one ``pin.forwardKinematics`` of the same
model in the same process, timed beside it in every round (``timing.interleaved_ratios``). Prints one JSON line.

Usage: ``placo_step.py URDF FRAME [--repeat N]``
"""

from __future__ import annotations

import argparse
import json
import re
import tempfile

import numpy as np
import pinocchio as pin
from timing import interleaved_ratios


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("urdf")
    parser.add_argument("frame")
    parser.add_argument("--repeat", type=int, default=2000)
    options = parser.parse_args()
    import placo

    # meshes are not needed for kinematics and their package:// paths do not resolve here
    with open(options.urdf) as file:
        text = re.sub(r"<visual>.*?</visual>|<collision>.*?</collision>", "", file.read(), flags=re.S)
    with tempfile.NamedTemporaryFile("w", suffix=".urdf", delete=False) as file:
        file.write(text)
    robot = placo.RobotWrapper(file.name, placo.Flags.ignore_collisions)
    rng = np.random.default_rng(0)
    lower, upper = robot.model.lowerPositionLimit[7:], robot.model.upperPositionLimit[7:]
    arm = rng.uniform(np.maximum(lower, -np.pi), np.minimum(upper, np.pi))
    for name, value in zip(robot.joint_names(), arm):
        robot.set_joint(name, float(value))
    robot.update_kinematics()
    target = robot.get_T_world_frame(options.frame) @ pin.SE3(pin.utils.rpyToMatrix(0.1, -0.1, 0.2),
                                                               np.array([0.05, -0.03, 0.04])).homogeneous
    solver = placo.KinematicsSolver(robot)
    solver.dt = 0.01
    solver.enable_joint_limits(True)
    solver.add_frame_task(options.frame, target).configure(options.frame, "soft", 1.0, 1.0)
    start = robot.state.q.copy()

    def step():
        robot.state.q = start  # the same start at every call: one step, not a converging run
        robot.update_kinematics()
        solver.solve(True)

    model, data, q = robot.model, robot.model.createData(), start.copy()
    ratios, reference = interleaved_ratios({"step": step}, lambda: pin.forwardKinematics(model, data, q),
                                           options.repeat)
    print(json.dumps({"pin": pin.__version__, "nv": int(model.nv), "fk_us": reference * 1e6,
                      "step_us": ratios["step"] * reference * 1e6, "ratio": ratios["step"]}))


if __name__ == "__main__":
    main()
