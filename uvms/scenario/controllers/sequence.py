"""A ``[[phases]]`` scenario's controller: several frames, claws and a claw distance, the vehicle held
(:class:`uvms.control.sequence.SequenceController`)."""

from __future__ import annotations

from ...control.sequence import Phase, PhasePlan, SequenceController
from ...errors import ScenarioError, UVMSError
from ..solver import scenario_solver
from ..spec import ScenarioSpec
from .parts import Parts, Setup


def build_sequence(spec: ScenarioSpec, parts: Parts) -> Setup:
    """The phases from the given q0, the solver (of any number of levels: vehicle, distance, frames, joints) built
    per phase; the task and trajectory of the run are the first frame's (what the sequence needs of ``[initial]``
    and ``[solver]`` is checked where the file is read: :func:`uvms.scenario.spec.scenario.check_initial`).

    Raises:
        ScenarioError: a solver of a fixed number of levels; what the sequence refuses (a frame, joint or claw).
    """
    robot = parts.robot
    frames = spec.task.frames or robot.ee_frames
    factory = scenario_solver(robot, spec.solver, float(spec.simulation.dt), any_levels="a sequence scenario")
    phases = [Phase(name=phase.name or f"phase {index + 1}", duration=float(phase.duration),
                    offsets=phase.offsets, joints=phase.joints, distance=phase.distance)
              for index, phase in enumerate(spec.phases)]
    plan = PhasePlan(robot, parts.q0, frames, phases)
    try:
        controller = SequenceController(robot, plan, factory, hold_vehicle=spec.vehicle.hold)
    except UVMSError as exc:
        raise ScenarioError(f"solver: {exc}") from None
    return parts.setup(controller, task=controller.frame_tasks[0], trajectory=plan.frame_trajectory(frames[0]),
                       plan=plan)
