"""Set-based task priority and the QP hierarchy against pink's weighted QP, on the BlueROV2 + Alpha 5.

Objectives, highest priority first: arm joint position limits, vehicle attitude (tilt <= 5 deg), then the
end-effector pose task; arm joint (the model's: 0.5 rad/s, the jaw 10 m/s) and vehicle (0.5 m/s, 0.5 rad/s)
speed limits as bounds. Step times are ratios to one ``pin.forwardKinematics`` on the same model measured in the same
run (interleaved, median over repeats; this machine is shared and noisy: absolute times are not comparable).
Then every method runs ``--steps`` steps from each of ``--starts`` seeded random starts (inside the limits,
and a tenth of them 0.01-0.10 rad past one joint limit) towards a random reachable target, and the
violations of the position and speed limits and the infeasible reports (or exceptions) are counted; the
table adds the vehicle tilt (runs that went past 5 deg, the largest tilt) and, for the starts outside a
limit, how many went further out and how many were back inside at the end.

    pip install -e ".[bench]"
    python benchmarks/bench_set_based.py [--starts 1000] [--steps 50] [--repeat 300] [--dt 0.05]

pink gets ConfigurationLimit + VelocityLimit (the same speed box over v, vehicle entries included), the
same FrameTask, and what it can express of the rest, as weighted costs of one QP: the attitude as a
FrameTask on the vehicle body (roll and pitch towards level, cost 1, no position cost) and a PostureTask
(cost 1e-3) as regularization. pink cannot express strict priority (the end-effector task trades off
against the attitude instead of giving way to it) nor the attitude as an inequality (it pulls the vehicle
level everywhere instead of only keeping the tilt below 5 deg). Its task gain is the same feedback rate
as ours (pink's gain is per step: K dt). Started outside a limit, pink is called with
``safety_break=False`` (with the default it refuses at once, NotWithinConfigurationLimits).
"""

from __future__ import annotations

import argparse
import collections
import logging
import statistics
import time
import warnings

import numpy as np
import pinocchio as pin

import uvms
from uvms.robot.limits import Limit
from uvms.solvers import SetBasedSolver, Solver
from uvms.tasks import FrameTask
from uvms.tasks.objectives import JointLimits, JointVelocityLimits, VehicleAttitude, VehicleVelocityLimits
from uvms.tasks.objectives.base import vehicle_frame_id

DT = 0.05  # [s]
GAIN = 2.0  # [1/s], the pose task's feedback gain (pink: GAIN * DT per step)
MAX_TILT = np.radians(5.0)  # [rad]
VEHICLE_MAX = (0.5, 0.5)  # [m/s, rad/s]
OUTSIDE_FRACTION = 0.1  # of the starts, one joint past its limit
TOLERANCE = 1e-9


class Problem:
    """The model, the objectives of one start and the bounds every method is checked against."""

    def __init__(self) -> None:
        self.robot = uvms.load("bluerov2_alpha5")
        robot = self.robot
        self.limit = Limit.joint_positions(robot)
        self.joint_speed = JointVelocityLimits(robot)  # the model's <limit velocity>
        self.vehicle_speed = VehicleVelocityLimits(robot, VEHICLE_MAX)
        self.maximum = np.minimum(self.joint_speed.maximum, self.vehicle_speed.maximum)  # (nv,)
        self.above = [JointLimits(robot, band=0.2), VehicleAttitude(robot, MAX_TILT),
                      self.joint_speed, self.vehicle_speed]
        self.ee = robot.frame_id()
        self.vehicle_frame = vehicle_frame_id(robot, "benchmark")
        self.data = robot.model.createData()

    def levels(self, target: pin.SE3) -> list:
        return [*self.above, FrameTask(self.robot, target=target)]

    def starts(self, count: int, seed: int = 0) -> list[tuple[np.ndarray, pin.SE3, bool]]:
        """(q0, target, started outside) per start: vehicle tilt <= 4 deg, arm inside its limits or one joint
        0.01-0.10 rad past; the target is the end effector at a configuration the vehicle reaches level
        (vehicle within 0.3 m and 0.3 rad of yaw, arm uniform inside its limits)."""
        robot, limit = self.robot, self.limit
        rng = np.random.default_rng(seed)
        starts = []
        for index in range(count):
            tilt = np.radians(4.0) * np.sqrt(rng.uniform())
            direction = rng.uniform(-np.pi, np.pi)
            base = np.r_[rng.uniform(-1, 1, 2), rng.uniform(-6, -4), tilt * np.cos(direction),
                         tilt * np.sin(direction), rng.uniform(-np.pi, np.pi)]
            arm = rng.uniform(limit.lower, limit.upper)
            outside = index % round(1 / OUTSIDE_FRACTION) == 0
            if outside:  # one revolute joint (not the 0.015 m jaw) past a limit
                joint = rng.integers(0, robot.n_arm - 1)
                past = rng.uniform(0.01, 0.10)
                arm[joint] = limit.upper[joint] + past if rng.uniform() < 0.5 else limit.lower[joint] - past
            goal_base = np.r_[base[:3] + rng.uniform(-0.3, 0.3, 3), 0.0, 0.0, base[5] + rng.uniform(-0.3, 0.3)]
            target = robot.fk(robot.configuration(base=goal_base, arm=rng.uniform(limit.lower, limit.upper)))
            starts.append((robot.configuration(base=base, arm=arm), target, outside))
        return starts

    def outside(self, q: np.ndarray) -> np.ndarray:
        """How far each arm coordinate is past its position limits (n_arm,), 0 inside."""
        arm = self.robot.arm_configuration(q)
        return np.maximum(np.maximum(self.limit.lower - arm, arm - self.limit.upper), 0.0)

    def tilt(self, q: np.ndarray) -> float:
        """Angle between the vehicle's z axis and world z [rad] (VehicleAttitude's value)."""
        pin.framesForwardKinematics(self.robot.model, self.data, q)
        return float(np.arccos(np.clip(self.data.oMf[self.vehicle_frame].rotation[2, 2], -1.0, 1.0)))

    def pose_error(self, q: np.ndarray, target: pin.SE3) -> float:
        """|[p_target - p, log3(R_target R^T)]| [m, rad] of the end effector."""
        pose = self.robot.fk(q)
        return float(np.linalg.norm(np.r_[target.translation - pose.translation,
                                          pin.log3(target.rotation @ pose.rotation.T)]))


# ------------------------------------------------------------------------------------------- steppers
def ours(solver_class: type[Solver], problem: Problem):
    """A stepper (q, levels) -> (q+, v, infeasible) of a SetBasedSolver or HQPSolver built at every step (one
    Configuration moved to q, as pink's is)."""
    configuration = uvms.Configuration(problem.robot, problem.robot.neutral())

    def stepper(q, levels):
        configuration.update(q, check=False)  # q from pin.integrate
        try:
            result = solver_class(problem.robot, levels, dt=DT, gain=GAIN).step(configuration, DT)
        except Exception:  # noqa: BLE001 - counted as infeasible, like pink's
            return q, None, True
        statuses = result.extras.get("solver_status", ())
        infeasible = not np.all(np.isfinite(result.v)) or not all(s.startswith("optimal") for s in statuses)
        return configuration.q, result.v, infeasible
    return stepper


class PreparedStepper:
    """A solver built once per start (its levels checked and prepared there, as pink's tasks are in
    ``PinkStepper.set_target``) stepping one Configuration moved to q (as pink's configuration is): a step is
    ``Configuration.update``, its velocity (diagnostics computed only when read) and the integration."""

    def __init__(self, problem: Problem, solver_class: type[Solver] = SetBasedSolver) -> None:
        self.problem, self.solver_class, self.solver = problem, solver_class, None
        self.configuration = uvms.Configuration(problem.robot, problem.robot.neutral())

    def set_target(self, target: pin.SE3, q0: np.ndarray) -> None:  # noqa: ARG002 - PinkStepper's signature
        self.solver = self.solver_class(self.problem.robot, self.problem.levels(target), gain=GAIN, dt=DT)

    def __call__(self, q, levels=None):  # noqa: ARG002 - the same signature as ours
        configuration = self.configuration
        configuration.update(q, check=False)  # q from pin.integrate
        try:
            result = self.solver.step(configuration, DT)
        except Exception:  # noqa: BLE001 - counted as infeasible, like pink's
            return q, None, True
        v = result.v
        statuses = result.extras.get("solver_status", ())
        infeasible = not np.all(np.isfinite(v)) or not all(s.startswith("optimal") for s in statuses)
        return configuration.q, v, infeasible


class PinkStepper:
    """pink's solve_ik with ConfigurationLimit + VelocityLimit + the same FrameTask, attitude and posture costs."""

    def __init__(self, problem: Problem) -> None:
        import pink
        from pink.limits import ConfigurationLimit, VelocityLimit

        self.pink = pink
        robot = problem.robot
        self.model = robot.model.copy()
        self.model.velocityLimit = problem.maximum  # the same box over v as ours, vehicle entries included
        self.configuration = pink.Configuration(self.model, self.model.createData(), robot.neutral())
        self.limits = [ConfigurationLimit(self.model), VelocityLimit(self.model)]
        self.ee_task = pink.tasks.FrameTask(robot.model.frames[problem.ee].name, position_cost=1.0,
                                            orientation_cost=1.0, gain=GAIN * DT)
        self.level_task = pink.tasks.FrameTask(robot.model.frames[problem.vehicle_frame].name, position_cost=0.0,
                                               orientation_cost=[1.0, 1.0, 0.0], gain=GAIN * DT)
        self.posture = pink.tasks.PostureTask(cost=1e-3)
        self.vehicle_frame = problem.vehicle_frame
        self.failures: collections.Counter[str] = collections.Counter()
        self.counting = False

    def set_target(self, target: pin.SE3, q0: np.ndarray) -> None:
        self.ee_task.set_target(target)
        self.posture.set_target(q0)

    def refuses(self, q: np.ndarray) -> bool:
        """Whether solve_ik with its default safety_break=True refuses q (NotWithinConfigurationLimits)."""
        from pink.exceptions import NotWithinConfigurationLimits

        self.configuration.update(q)
        try:
            self.configuration.check_limits(safety_break=True)
        except NotWithinConfigurationLimits:
            return True
        return False

    def __call__(self, q, levels=None):  # noqa: ARG002 - the same signature as ours
        configuration = self.configuration
        configuration.update(q)
        rotation = configuration.data.oMf[self.vehicle_frame].rotation
        level = pin.SE3(pin.utils.rotate("z", np.arctan2(rotation[1, 0], rotation[0, 0])),
                        configuration.data.oMf[self.vehicle_frame].translation)
        self.level_task.set_target(level)  # roll = pitch = 0 at the current yaw
        try:
            v = self.pink.solve_ik(configuration, [self.ee_task, self.level_task, self.posture], DT,
                                   solver="daqp", limits=self.limits, safety_break=False)
        except Exception as error:  # noqa: BLE001 - NoSolutionFound (the QP is infeasible) or any other failure
            if self.counting:
                self.failures[type(error).__name__] += 1
            return q, None, True
        if v is None or not np.all(np.isfinite(v)):
            return q, None, True
        return pin.integrate(self.model, q, v * DT), v, False


# ---------------------------------------------------------------------------------------- measures
def step_times(problem: Problem, steppers: dict, starts: list, repeat: int, number: int = 5) -> dict[str, float]:
    """Median over ``repeat`` interleaved rounds of (time of one step / time of one pin.forwardKinematics),
    each round at one of the first 20 starts (their objectives active or not, as they come)."""
    model, data = problem.robot.model, problem.robot.model.createData()
    cases = [(q, target, problem.levels(target)) for q, target, _ in starts[:20]]
    ratios: dict[str, list[float]] = {name: [] for name in steppers}
    references = []
    for round_ in range(repeat):
        q, target, levels = cases[round_ % len(cases)]
        for stepper in steppers.values():  # pink's tasks and uvms's prepared solver: outside the timing
            if hasattr(stepper, "set_target"):
                stepper.set_target(target, q)
        started = time.perf_counter()
        for _ in range(10 * number):
            pin.forwardKinematics(model, data, q)
        reference = (time.perf_counter() - started) / (10 * number)
        references.append(reference)
        for name, stepper in steppers.items():
            started = time.perf_counter()
            for _ in range(number):
                stepper(q, levels)
            ratios[name].append((time.perf_counter() - started) / number / reference)
    result = {name: statistics.median(values) for name, values in ratios.items()}
    result["_fk_us"] = statistics.median(references) * 1e6
    return result


def run_starts(problem: Problem, name: str, stepper, starts: list, steps: int) -> dict[str, float]:
    """Counts over the starts: runs with a position / speed / tilt violation, infeasible runs, final error."""
    position_runs = velocity_runs = tilt_runs = infeasible_runs = 0
    further_runs = back_inside = 0
    position_steps = velocity_steps = 0
    errors, worst_tilt, worst_speed = [], 0.0, 0.0
    for q0, target, outside in starts:
        levels = problem.levels(target)
        if hasattr(stepper, "set_target"):
            stepper.set_target(target, q0)
        q, past = q0, problem.outside(q0)
        position_bad = velocity_bad = tilt_bad = infeasible = further = False
        for _ in range(steps):
            q_next, v, failed = stepper(q, levels)
            if failed:
                infeasible = True
                break
            ratio = float(np.max(np.abs(v) / problem.maximum))
            worst_speed = max(worst_speed, ratio)
            if np.any(np.abs(v) > problem.maximum * (1 + TOLERANCE)):
                velocity_bad, velocity_steps = True, velocity_steps + 1
            now = problem.outside(q_next)
            if not outside and now.max() > TOLERANCE:
                position_bad, position_steps = True, position_steps + 1
            if outside and np.any(now > past + TOLERANCE):
                further = True
            past = np.minimum(past, now) if outside else past
            tilt = problem.tilt(q_next)
            worst_tilt = max(worst_tilt, tilt)
            tilt_bad |= tilt > MAX_TILT + TOLERANCE
            q = q_next
        position_runs += position_bad
        velocity_runs += velocity_bad
        tilt_runs += tilt_bad
        infeasible_runs += infeasible
        further_runs += outside and further
        back_inside += outside and not infeasible and problem.outside(q).max() <= TOLERANCE
        errors.append(problem.pose_error(q, target))
    return {"position": position_runs, "position_steps": position_steps, "velocity": velocity_runs,
            "velocity_steps": velocity_steps, "infeasible": infeasible_runs, "error": statistics.median(errors),
            "tilt_runs": tilt_runs, "max_tilt": np.degrees(worst_tilt), "further": further_runs,
            "back_inside": back_inside, "max_speed_ratio": worst_speed}


def main() -> None:
    global DT  # noqa: PLW0603 - the steppers read the module's step
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--starts", type=int, default=1000, help="random starts (seeded)")
    parser.add_argument("--steps", type=int, default=50, help="steps per start")
    parser.add_argument("--repeat", type=int, default=300, help="interleaved timing rounds")
    parser.add_argument("--dt", type=float, default=DT, help="step [s]")
    options = parser.parse_args()
    DT = options.dt
    logging.disable(logging.WARNING)  # pink logs every start outside a limit (safety_break=False)
    problem = Problem()
    steppers = {"uvms SetBasedSolver (built per start)": PreparedStepper(problem),
                "uvms HQPSolver (built per start)": PreparedStepper(problem, uvms.HQPSolver),
                "uvms SetBasedSolver (built per step)": ours(uvms.SetBasedSolver, problem),
                "uvms HQPSolver (built per step)": ours(uvms.HQPSolver, problem)}
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            import pink
        steppers["pink"] = PinkStepper(problem)
        pink_note = f"pink {pink.__version__}"
    except Exception as error:  # noqa: BLE001 - any import/compatibility failure: skip pink, say why
        pink_note = f"pink skipped: {type(error).__name__}: {error}"
        print(pink_note)
    starts = problem.starts(options.starts)
    outside = sum(start[2] for start in starts)
    began = time.perf_counter()
    times = step_times(problem, steppers, starts, options.repeat)
    if "pink" in steppers:
        steppers["pink"].counting = True
    rows = {name: run_starts(problem, name, stepper, starts, options.steps) for name, stepper in steppers.items()}
    robot = problem.robot
    print(f"{robot.name} (nv = {robot.nv}), dt = {DT} s, pose gain {GAIN}/s, tilt <= 5 deg, speeds <= model's "
          f"arm limits and {VEHICLE_MAX} m/s, rad/s; {pink_note}, pin {pin.__version__}, numpy {np.__version__}")
    print(f"pin.forwardKinematics = {times.pop('_fk_us'):.2f} us in this run; {options.starts} starts "
          f"({outside} one joint outside a limit), {options.steps} steps each; counts are runs "
          f"(steps in parentheses)\n")
    print("| method | step time [x FK] | violations (position) | violations (velocity) | infeasible "
          "| final task error median | tilt > 5 deg | max tilt [deg] | outside starts: further out / back inside |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, row in rows.items():
        print(f"| {name} | {times[name]:.1f} | {row['position']} ({row['position_steps']}) "
              f"| {row['velocity']} ({row['velocity_steps']}) | {row['infeasible']} | {row['error']:.1e} "
              f"| {row['tilt_runs']} | {row['max_tilt']:.2f} | {row['further']} / {row['back_inside']} of {outside} |")
    if "pink" in steppers:
        pink_stepper = steppers["pink"]
        refused = sum(pink_stepper.refuses(q0) for q0, _, out in starts if out)
        print(f"\npink's failures: {dict(pink_stepper.failures) or 'none'} (a run stops at its first); with its "
              f"default safety_break=True solve_ik refuses {refused} of the {outside} starts outside a limit "
              f"(NotWithinConfigurationLimits)")
    print("\n(max |v_i|/max_i: " + ", ".join(f"{n} {r['max_speed_ratio']:.12f}" for n, r in rows.items())
          + f"; {time.perf_counter() - began:.0f} s)")


if __name__ == "__main__":
    main()
