"""The typed scenario spec: a scenario file read and checked once into frozen dataclasses, one per section.

``keys`` (a section's keys: type, default, allowed values, bound and meaning, the one source of the checks and of the
docs' scenario reference), ``sections``, ``dynamics`` and ``controller`` (the section dataclasses; ``[controller]``'s
MPC keys made from :class:`uvms.control.mpc.settings.MPCSettings`), ``scenario`` (:class:`ScenarioSpec` and its check).
:func:`uvms.scenario.read_scenario` reads a file into a :class:`ScenarioSpec`.
"""

from .controller import CHOSEN_CONTROLLERS, ControllerSpec, controller_types
from .dynamics import PLANT_TYPES, ExcitationSpec, PlantSpec, VehicleControlSpec
from .keys import MAX_MAGNITUDE, NUMBER, NUMBERS, REQUIRED, Bound, Key, Section
from .scenario import ARRAYS, SECTIONS, InequalitySpec, ScenarioSpec, check_scenario, key_of
from .sections import (
    InitialSpec,
    LabelSpec,
    ModelSpec,
    OutputsSpec,
    PhaseSpec,
    SimulationSpec,
    SolverSpec,
    StudySpec,
    TaskSpec,
    TrajectorySpec,
    VehicleSpec,
)

__all__ = ["ARRAYS", "Bound", "CHOSEN_CONTROLLERS", "ControllerSpec", "ExcitationSpec", "InequalitySpec", "InitialSpec",
           "Key", "LabelSpec", "MAX_MAGNITUDE", "ModelSpec", "NUMBER", "NUMBERS", "OutputsSpec", "PLANT_TYPES",
           "PhaseSpec", "PlantSpec", "REQUIRED", "SECTIONS", "ScenarioSpec", "Section", "SimulationSpec", "SolverSpec",
           "StudySpec", "TaskSpec", "TrajectorySpec", "VehicleControlSpec", "VehicleSpec", "check_scenario",
           "controller_types", "key_of"]
