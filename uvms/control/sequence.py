"""Phase sequences for several end effectors: move both arms, keep the claws apart, open and close the claws.

A sequence is a list of phases. Each phase moves some frames by a displacement
[m], drives named joints (claws) to values and optionally the distance between
the first two frames to a value, all along a quintic time law (rest to rest),
while the vehicle holds its pose. The controller gives the levels — vehicle,
then the relative distance, then frames and joints — to its solver, any
that takes any number of levels (``clik`` stacks them, ``task_priority``
prioritizes them). xiang2019's gripping sequence (open the arms, lower
onto the target, grip) is ``scenarios/xiang2019_grip.toml``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from ..dynamics.plant.command import Command, State
from ..errors import UVMSError
from ..robot.configuration import Configuration, configurations
from ..robot.robot import Robot
from ..solvers.base import Solver, SolverFactory
from ..tasks import DistanceTask, FrameTask, JointTask, VehicleTask
from ..tasks.vehicle import VELOCITY_NAMES
from ..trajectory import PolynomialLaw, PoseSample

POSITION_AXES = ("x", "y", "z")


@dataclass(frozen=True)
class Phase:
    """One phase of a sequence.

    Attributes:
        name: label (figures, metrics).
        duration: [s] > 0.
        offsets: frame -> displacement (3,) [m] in world axes over the phase.
        joints: joint -> value at the end of the phase [rad or m].
        distance: distance between the first two frames at the end of the phase [m], or None (free). Their
            targets then move symmetrically along the line joining them (midpoint kept, after the offsets),
            so the claws close on (or open around) a point.
    """

    name: str
    duration: float
    offsets: Mapping[str, Sequence[float]] = field(default_factory=dict)
    joints: Mapping[str, float] = field(default_factory=dict)
    distance: float | None = None


@dataclass(frozen=True)
class Targets:
    """Everything the tasks need at one time: values and rates."""

    phase: int
    positions: dict[str, tuple[np.ndarray, np.ndarray]]  # frame -> (p (3,) [m], p' (3,) [m/s])
    joints: dict[str, tuple[float, float]]  # joint -> (value, rate)
    distance: tuple[float, float] | None  # (d [m], d' [m/s]), None in phases that leave it free


class PhasePlan:
    """Piecewise-quintic targets of a phase sequence, starting from the configuration q0.

    Args:
        robot: the model.
        q0: initial configuration (nq,).
        frames: the controlled frames (the first two define the distance).
        phases: the phases, in order.
    """

    def __init__(self, robot: Robot, q0: np.ndarray, frames: Sequence[str], phases: Sequence[Phase]) -> None:
        if not phases:
            raise UVMSError("a sequence needs at least one phase")
        self.robot, self.frames, self.phases = robot, list(frames), list(phases)
        self.uses_distance = any(phase.distance is not None for phase in phases)
        if self.uses_distance and len(self.frames) < 2:
            raise UVMSError("a phase distance needs two frames in task.frames")
        self._check_names()
        start = Configuration(robot, q0)
        poses = {frame: start.pose(robot.frame_id(frame)) for frame in self.frames}
        starts = {frame: pose.translation.copy() for frame, pose in poses.items()}
        self.rotations = {frame: pose.rotation.copy() for frame, pose in poses.items()}
        joints = {name: float(q0[robot.joint(name).idx_q]) for name in self.joint_names}
        self.boundaries = [(dict(starts), dict(joints))]  # target values at the start of each phase, and the end
        for phase in self.phases:
            starts = {f: starts[f] + np.asarray(phase.offsets.get(f, np.zeros(3)), dtype=float) for f in self.frames}
            if phase.distance is not None:
                starts = self._spread(starts, phase.distance)
            joints = {**joints, **{name: float(value) for name, value in phase.joints.items()}}
            self.boundaries.append((dict(starts), dict(joints)))
        self.times = np.concatenate([[0.0], np.cumsum([phase.duration for phase in self.phases])])
        self.laws = [PolynomialLaw(distance=1.0, duration=phase.duration, degree=5) for phase in self.phases]

    def _spread(self, positions: dict[str, np.ndarray], distance: float) -> dict[str, np.ndarray]:
        """Move the first two frames' targets symmetrically along their line to ``distance`` apart (midpoint kept)."""
        a, b = positions[self.frames[0]], positions[self.frames[1]]
        length = np.linalg.norm(b - a)
        if length < 1e-9:
            raise UVMSError(f"the targets of {self.frames[0]!r} and {self.frames[1]!r} coincide: no line to spread on")
        middle, direction = 0.5 * (a + b), (b - a) / length
        return {**positions, self.frames[0]: middle - 0.5 * distance * direction,
                self.frames[1]: middle + 0.5 * distance * direction}

    @property
    def joint_names(self) -> list[str]:
        """Joints driven by some phase, in order of appearance."""
        return list(dict.fromkeys(name for phase in self.phases for name in phase.joints))

    @property
    def duration(self) -> float:
        """Total time [s]."""
        return float(self.times[-1])

    def _check_names(self) -> None:
        for phase in self.phases:
            if not (np.isfinite(phase.duration) and phase.duration > 0):
                raise UVMSError(f"phase {phase.name!r}: duration must be finite and > 0, got {phase.duration!r}")
            unknown = sorted(set(phase.offsets) - set(self.frames))
            if unknown:
                raise UVMSError(f"phase {phase.name!r}: offsets for {', '.join(unknown)}, which are not task frames; "
                                f"valid: {', '.join(self.frames)}")
            for frame, offset in phase.offsets.items():
                if np.shape(offset) != (3,) or not np.all(np.isfinite(offset)):
                    raise UVMSError(f"phase {phase.name!r}: offset of {frame!r} must be 3 finite numbers [m]")
            for name, value in phase.joints.items():
                self.robot.joint_id(name)  # unknown joints raise with the close names
                if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
                    raise UVMSError(f"phase {phase.name!r}: joint {name!r} needs a finite number, got {value!r}")
            if phase.distance is not None and not (np.isfinite(phase.distance) and phase.distance > 0):
                raise UVMSError(f"phase {phase.name!r}: distance must be finite and > 0 [m], got {phase.distance!r}")

    def phase_at(self, t: float) -> int:
        """Index of the phase running at time t (the last one after the end)."""
        return int(np.clip(np.searchsorted(self.times, t, side="right") - 1, 0, len(self.phases) - 1))

    def __call__(self, t: float) -> Targets:
        index = self.phase_at(t)
        timing = self.laws[index](t - self.times[index])
        (p0, j0), (p1, j1) = self.boundaries[index], self.boundaries[index + 1]
        positions = {f: (p0[f] + timing.s * (p1[f] - p0[f]), timing.ds * (p1[f] - p0[f])) for f in self.frames}
        joints = {n: (j0[n] + timing.s * (j1[n] - j0[n]), timing.ds * (j1[n] - j0[n])) for n in j0}
        return Targets(index, positions, joints, self._distance(index, timing))

    def _distance(self, index: int, timing) -> tuple[float, float] | None:
        """Distance target of a phase that sets one: from the frames' targets at its start to its value."""
        final = self.phases[index].distance
        if final is None:
            return None
        starts = self.boundaries[index][0]
        start = float(np.linalg.norm(starts[self.frames[1]] - starts[self.frames[0]]))
        return start + timing.s * (final - start), timing.ds * (final - start)

    def frame_trajectory(self, frame: str):
        """t -> PoseSample of one frame (its initial orientation kept), for records and figures."""
        def sample(t: float) -> PoseSample:
            position, velocity = self(t).positions[frame]
            return PoseSample(pin.SE3(self.rotations[frame], position), np.concatenate([velocity, np.zeros(3)]),
                              np.zeros(6))
        sample.duration = self.duration  # type: ignore[attr-defined]
        return sample


class SequenceController:
    """The :class:`~uvms.control.base.Controller` of a PhasePlan's tasks on a kinematic plant:
    ``Command(velocity=v, info=SolverResult)``.

    Args:
        robot: the model.
        plan: the targets.
        solver: a solver that takes any number of levels (e.g. CLIK: all tasks stacked; task priority:
            vehicle > distance > frames and joints), built once per level set.
        hold_vehicle: keep the vehicle at rest (a floating/planar base); False lets it move.

    Raises:
        UVMSError: a solver that needs a fixed number of levels; the solver's own errors.
    """

    def __init__(self, robot: Robot, plan: PhasePlan, solver: SolverFactory, *, hold_vehicle: bool = True) -> None:
        if solver.cls.level_count is not None:
            raise UVMSError(f"a sequence needs a solver of any number of levels (vehicle, distance, frames and "
                            f"joints); {solver.cls.__name__} needs {solver.cls.level_count}")
        self.robot, self.plan = robot, plan
        self.frame_tasks = [FrameTask(robot, frame, axes=POSITION_AXES) for frame in plan.frames]
        start = plan(0.0).joints
        self.joint_task = JointTask(robot, {name: value for name, (value, _) in start.items()}) if start else None
        self.distance_task = (DistanceTask(robot, plan.frames[0], plan.frames[1]) if plan.uses_distance else None)
        self.vehicle_task = None
        if hold_vehicle and robot.base_type != "fixed":
            self.vehicle_task = VehicleTask(robot, velocities={name: 0.0 for name in VELOCITY_NAMES[robot.base_type]})
        # one solver per level set, built once: without the distance task, and with it when a phase sets one
        self.solvers: dict[bool, Solver] = {with_distance: solver(self.levels(with_distance))
                                            for with_distance in ((False, True) if plan.uses_distance else (False,))}
        self._configuration: Configuration | None = None  # moved to each q asked about

    def set_targets(self, t: float) -> Targets:
        """Point every task at its target of time t."""
        targets = self.plan(t)
        for task in self.frame_tasks:
            position, velocity = targets.positions[task.frame]
            task.set_target(pin.SE3(self.plan.rotations[task.frame], position))
            task.set_target_velocity(np.concatenate([velocity, np.zeros(3)]))
        if self.joint_task is not None:
            self.joint_task.set_target({n: v for n, (v, _) in targets.joints.items()},
                                       {n: rate for n, (_, rate) in targets.joints.items()})
        if targets.distance is not None:
            self.distance_task.set_target(*targets.distance)
        return targets

    def levels(self, with_distance: bool) -> list[list]:
        """Task levels, highest priority first: vehicle, distance (when active), frames and joints."""
        primary = list(self.frame_tasks) + ([self.joint_task] if self.joint_task is not None else [])
        levels = [[self.vehicle_task] if self.vehicle_task else [], [self.distance_task] if with_distance else [],
                  primary]
        return [level for level in levels if level]

    def reset(self, state: State, t: float = 0.0) -> None:
        """Nothing to reset: the targets depend on time only."""

    def command(self, state: State, t: float) -> Command:
        """``Command(velocity=v (nv,), info=the SolverResult)`` at (t, q)."""
        targets = self.set_targets(t)
        if self._configuration is None:
            self._configuration = Configuration(self.robot, state.q, check=False)
        else:
            self._configuration.update(state.q, check=False)
        result = self.solvers[targets.distance is not None].velocity(self._configuration)
        return Command(velocity=result.v, info=result)


def frame_positions(robot: Robot, frames: Sequence[str], q: np.ndarray) -> dict[str, np.ndarray]:
    """Position (N, 3) [m] of each frame along a run (q (N, nq)): one Configuration moved to each row."""
    ids = {frame: robot.frame_id(frame) for frame in frames}
    positions = {frame: np.empty((len(q), 3)) for frame in frames}
    for row, state in enumerate(configurations(robot, q)):
        for frame, frame_id in ids.items():
            positions[frame][row] = state.pose(frame_id).translation
    return positions


def frame_errors(plan: PhasePlan, t: np.ndarray, positions: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Position error norm (N,) [m] of every plan frame along a run (t (N,), its :func:`frame_positions`)."""
    return {frame: np.array([np.linalg.norm(plan(time_).positions[frame][0] - position)
                             for time_, position in zip(t, positions[frame])]) for frame in plan.frames}


def sequence_metrics(robot: Robot, plan: PhasePlan, t: np.ndarray, q: np.ndarray) -> dict:
    """Metrics of a sequence run: per-frame tracking errors, errors at the end of every phase, final distance.

    Args:
        robot: the model; plan: the targets; t: (N,) [s]; q: (N, nq).
    """
    positions = frame_positions(robot, plan.frames, q)
    errors = frame_errors(plan, t, positions)
    ends = [int(np.argmin(np.abs(t - end))) for end in plan.times[1:]]
    metrics = {
        "frames": {frame: {"max_position_error": float(error.max()), "final_position_error": float(error[-1])}
                   for frame, error in errors.items()},
        "phase_end_position_error": {
            phase.name: max(float(errors[frame][row]) for frame in plan.frames)
            for phase, row in zip(plan.phases, ends)},
        "max_frame_position_error": float(max(error.max() for error in errors.values())),
    }
    if plan.joint_names:
        final = {name: float(q[-1, robot.joint(name).idx_q]) for name in plan.joint_names}
        metrics["final_joints"] = final
    if len(plan.frames) >= 2:
        first, second = positions[plan.frames[0]], positions[plan.frames[1]]
        distance = np.array([np.linalg.norm(b - a) for a, b in zip(first, second)])  # (N,) [m] between the two
        metrics["final_distance"] = float(distance[-1])
        final_target = plan(t[-1]).distance
        if final_target is not None:
            metrics["final_distance_error"] = float(abs(final_target[0] - distance[-1]))
    return metrics
