"""An open-loop excitation's controller (``[excitation]`` wrench with plant.thrusters): the model's thrusters driven
by a multi-sine body wrench for identification (:class:`uvms.scenario.excitation.ExcitationControl`)."""

from __future__ import annotations

import numpy as np

from ...dynamics.plant.actuated import ActuatedPlant
from ...errors import ScenarioError, UVMSError
from ..actuated import Actuation
from ..excitation import ExcitationControl, multisine
from ..spec import ScenarioSpec
from .parts import Parts, Setup


def build_excitation(spec: ScenarioSpec, parts: Parts) -> Setup:
    """The excitation of the thrusters alone (the plant built without fins, as identification's logs have it)."""
    actuation = scenario_excitation(parts.actuated, spec, parts.duration)
    return parts.setup(actuation.controller, actuation=actuation)


def scenario_excitation(actuated: ActuatedPlant, spec: ScenarioSpec, duration: float) -> Actuation:
    """The actuated part of an excitation scenario (``[excitation]`` with plant.thrusters): the model's thrusters
    driven open loop by the multi-sine, the arm held or moving; ``uvms run --bag`` then writes the log that
    ``uvms identify`` reads.

    Raises:
        ScenarioError: excitation.arm not one amplitude per arm joint, bad excitation values, or thrust commands
            beyond the thrusters' limits (the message gives the factor to scale excitation.wrench by); the rest is
            checked where the scenario is read (:func:`uvms.scenario.spec.dynamics.check_excitation`).
    """
    robot, thrusters = actuated.robot, actuated.thrusters
    section, dt = spec.excitation, float(spec.simulation.dt)
    if section.arm and len(section.arm) != robot.n_arm:
        raise ScenarioError(f"excitation.arm needs {robot.n_arm} amplitudes [rad or m] "
                            f"({', '.join(robot.arm_joint_names)}), got {len(section.arm)}; [] holds the arm")
    try:
        wrench = multisine(np.array(section.wrench), highest=float(section.highest),
                           components=int(section.components), seed=int(section.seed))
    except UVMSError as exc:
        raise ScenarioError(f"excitation: {' '.join(str(exc).split())}") from None
    controller = ExcitationControl(actuated, wrench, np.array(section.arm) if section.arm else None,
                                   float(section.arm_period))
    ratio = controller.peak_ratio(duration, dt)
    if ratio > 1.0:
        raise ScenarioError(f"excitation.wrench asks up to {ratio:.3g} times the thrusters' limits "
                            f"({thrusters.source}); scale it by {1.0 / ratio:.3g} or less so that the log's wrench is "
                            f"what was commanded")
    return Actuation(actuated, controller)
