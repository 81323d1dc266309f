"""One CLIK step, measured side by side against Pinocchio, a hand-written numpy step and pink.

Model: a 6-DOF floating base carrying a UR5 (6 + 6 DOF). The step is a pose
task with a diagonal W, DLS, a joint-limit null-space term, sigma_min read and integration on the manifold (the
pose CLIKSolver and the numpy step: no W, sigma_min not read). The prepared steps reset q before each step; the
loop steps one configuration on as a user does (``solver.step(configuration, dt)``), towards the target.
Times are ratios to one ``pin.forwardKinematics`` call measured in the same run
(this machine is shared and noisy: absolute times are not comparable).

    pip install -e ".[bench]"
    python benchmarks/bench_clik.py [--repeat 2000]

Pose IK has its own benchmark, ``benchmarks/bench_ik.py``. placo runs in an environment of its own (it pins an
older Pinocchio): with ``UVMS_PLACO_PYTHON`` naming that environment's Python, its step is measured there by
``placo_step.py`` (its ratio to that environment's own ``pin.forwardKinematics``) and printed beside uvms.

"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pinocchio as pin
from timing import interleaved_ratios

import uvms

DT = 0.01


def numpy_dls_step(robot: uvms.Robot, q: np.ndarray, target: pin.SE3, potential, damping=1e-6) -> np.ndarray:
    """A hand-written numpy CLIK step, as users write it (the '25x' reference of the issue)."""
    frame = robot.frame_id()
    jacobian = pin.computeFrameJacobian(robot.model, robot.data, q, frame, pin.LOCAL_WORLD_ALIGNED)
    pose = robot.data.oMf[frame]
    error = np.concatenate([target.translation - pose.translation, pin.log3(target.rotation @ pose.rotation.T)])
    inverse = jacobian.T @ np.linalg.solve(jacobian @ jacobian.T + damping**2 * np.eye(6), np.eye(6))
    z0 = -potential.gradient(q)
    v = inverse @ error + (np.eye(robot.nv) - inverse @ jacobian) @ z0
    return pin.integrate(robot.model, q, v * DT)


#: The Python of an environment with placo installed (``python -m venv /tmp/placo_env && /tmp/placo_env/bin/pip
#: install placo``), read from ``UVMS_PLACO_PYTHON``; unset: placo is skipped with that command printed.
PLACO_PYTHON = os.environ.get("UVMS_PLACO_PYTHON", "")
PLACO_HINT = ("placo skipped: python -m venv /tmp/placo_env && /tmp/placo_env/bin/pip install placo, "
              "then UVMS_PLACO_PYTHON=/tmp/placo_env/bin/python")


def placo_ratio(robot: uvms.Robot, repeat: int) -> dict | None:
    """placo's step on ``robot``'s URDF (its floating base), timed in placo's environment (``placo_step.py``).

    Returns:
        {"ratio": step / that environment's pin.forwardKinematics, "nv", "fk_us", "step_us", "pin"}, or None (with
        the reason printed) when ``UVMS_PLACO_PYTHON`` is unset or the run fails.
    """
    if not PLACO_PYTHON:
        print(PLACO_HINT)
        return None
    script = Path(__file__).with_name("placo_step.py")
    run = subprocess.run([PLACO_PYTHON, str(script), str(robot.source), robot.ee_frames[0], "--repeat", str(repeat)],
                         capture_output=True, text=True)
    if run.returncode != 0:
        print(f"placo skipped: {PLACO_PYTHON} {script.name} failed: {run.stderr.strip().splitlines()[-1:]}")
        return None
    return json.loads(run.stdout.strip().splitlines()[-1])


def clik_step_ratios(robot: uvms.Robot, repeat: int) -> dict[str, float]:
    """Cost of one CLIK step per implementation, relative to pin.forwardKinematics."""
    rng = np.random.default_rng(0)
    q = robot.random_configuration(rng)
    target = robot.fk(robot.random_configuration(rng))
    potential = uvms.tasks.MidRangePotential(robot)
    model, data = robot.model, robot.data
    task = uvms.FrameTask(robot, target=target)
    weights = np.linspace(1.0, 2.0, robot.nv)  # a diagonal W (the step has weights)
    pose = uvms.CLIKSolver(robot, task, gain=1.0, damping=1e-6, potential=potential, alpha=1.0)  # no W
    solver = uvms.CLIKSolver(robot, task, weights=weights, damping=1e-6, potential=potential, alpha=1.0)
    configuration = uvms.Configuration(robot, q)

    moving = uvms.Configuration(robot, q)

    def kept_step(kept: uvms.CLIKSolver) -> uvms.solvers.SolverResult:
        configuration.update(q, check=False)  # the same q at every call
        return kept.step(configuration, DT)

    calls = {
        "uvms CLIKSolver.step, pose task (built once, no W)": lambda: kept_step(pose),
        "uvms CLIKSolver built per step (general, with diagnostics)": lambda: uvms.CLIKSolver(
            robot, task, weights=weights, damping=1e-6, potential=potential, alpha=1.0).step(
            uvms.Configuration(robot, q, check=False), DT).sigma_min,
        "uvms CLIKSolver.step (built once, with W, sigma_min read)": lambda: kept_step(solver).sigma_min,
        "uvms CLIKSolver.step in a loop (built once, with W, sigma_min read; q moving)":
            lambda: solver.step(moving, DT).sigma_min,
    }
    calls["plain numpy DLS step"] = lambda: numpy_dls_step(robot, q, target, potential)
    try:
        import pink

        pink_configuration = pink.Configuration(robot.model.copy(), robot.model.copy().createData(), q)
        pink_task = pink.tasks.FrameTask(robot.ee_frames[0], position_cost=1.0, orientation_cost=1.0)
        pink_task.set_target(target)
        posture = pink.tasks.PostureTask(cost=1e-3)
        posture.set_target(q)

        def pink_step():
            pink_configuration.update(q)
            velocity = pink.solve_ik(pink_configuration, [pink_task, posture], DT, solver="daqp")
            return pin.integrate(pink_configuration.model, q, velocity * DT)

        calls["pink solve_ik step (daqp)"] = pink_step
    except ImportError:
        print("pink not installed: pip install -e '.[bench]'")
    ratios, reference = interleaved_ratios(calls, lambda: pin.forwardKinematics(model, data, q), repeat)
    placo = placo_ratio(robot, repeat)
    if placo is not None:
        ratios[f"placo KinematicsSolver.solve (pin {placo['pin']}, its own environment, nv = {placo['nv']})"] = \
            placo["ratio"]
    ratios["_reference_us"] = reference * 1e6
    return ratios


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=2000, help="calls per timing")
    options = parser.parse_args()
    robot = uvms.load(uvms.model.example_robot_urdf("ur5"), base="floating")
    ratios = clik_step_ratios(robot, options.repeat)
    print(f"One CLIK step, {robot.name} on a 6-DOF floating base (nv = {robot.nv}); "
          f"pin.forwardKinematics = {ratios.pop('_reference_us'):.2f} us in this run (goal: uvms <= 10x)\n")
    print("| implementation | time / pin.forwardKinematics |\n|---|---|")
    for label, ratio in ratios.items():
        print(f"| {label} | {ratio:.1f} |")
    print("\nPose IK: benchmarks/bench_ik.py (the TRAC-IK protocol at 1e-10, limits on, roboticstoolbox beside it)")


if __name__ == "__main__":
    main()
