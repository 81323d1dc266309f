"""The controllers a scenario can run, one module each, and :data:`CONTROLLERS`, their one registry.

:func:`uvms.scenario.build.build` makes the model, the start, the plant (:class:`~.parts.Parts`) and hands them to
``CONTROLLERS[spec.controller_kind]`` (:attr:`uvms.scenario.spec.ScenarioSpec.controller_kind`, chosen from the file
alone), which builds the controller and returns the run's :class:`~.parts.Setup`. A new controller is one module
with a builder ``(spec, parts) -> Setup`` and one entry here; ``controller.type = "<its name>"`` then selects it.
"""

from __future__ import annotations

from collections.abc import Callable

from ..spec import ScenarioSpec
from .actuated import build_actuated
from .excitation import build_excitation
from .gjm import build_gjm
from .mpc import build_mpc
from .parts import Parts, Setup
from .sequence import build_sequence
from .tracking import build_tracking

#: A controller's builder: the scenario and the parts build made -> the run.
ControllerBuilder = Callable[[ScenarioSpec, Parts], Setup]

#: controller kind -> its builder. The first five are chosen by the plant for ``controller.type = "solver"``
#: (:attr:`~uvms.scenario.spec.ScenarioSpec.controller_kind`); the others by ``controller.type`` naming them.
CONTROLLERS: dict[str, ControllerBuilder] = {
    "tracking": build_tracking,  # the kinematic plant
    "gjm": build_gjm,  # a passive vehicle: a dynamic plant without thrusters
    "actuated": build_actuated,  # plant.thrusters: the chain
    "excitation": build_excitation,  # plant.thrusters with excitation.wrench: open loop
    "sequence": build_sequence,  # [[phases]]
    "mpc": build_mpc,  # the whole-body MPC
}

__all__ = ["CONTROLLERS", "ControllerBuilder", "Parts", "Setup"]
