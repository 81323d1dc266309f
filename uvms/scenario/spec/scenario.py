"""The whole scenario: :class:`ScenarioSpec`, every section checked once (:func:`check_scenario`) and frozen."""

from __future__ import annotations

from collections.abc import Collection, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ...errors import ScenarioError, UVMSError
from ...io.names import NAME_RULE, is_plain_name
from ...numerics.integrate import step_count
from ...tasks.objectives import check_table, file_keys
from .controller import ControllerSpec, check_controller
from .dynamics import ExcitationSpec, PlantSpec, VehicleControlSpec, check_plant
from .keys import NUMBER, Key, Section, check_range, thaw
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

#: The sections of a scenario file (one table each), in the order of the scenario reference; ``[[phases]]``
#: (:class:`PhaseSpec`) and ``[[inequalities]]`` (:class:`InequalitySpec`) are arrays of tables besides them.
SECTIONS: dict[str, type[Section]] = {
    "scenario": LabelSpec, "model": ModelSpec, "task": TaskSpec, "trajectory": TrajectorySpec, "solver": SolverSpec,
    "vehicle": VehicleSpec, "initial": InitialSpec, "simulation": SimulationSpec, "plant": PlantSpec,
    "vehicle_control": VehicleControlSpec, "controller": ControllerSpec, "excitation": ExcitationSpec,
    "outputs": OutputsSpec, "study": StudySpec,
}
ARRAYS = ("phases", "inequalities")
REQUIRED_SECTIONS = ("model", "trajectory", "simulation")
SEQUENCE_REQUIRED_SECTIONS = ("model", "phases", "simulation")
ANIMATION_SUFFIXES = (".gif", ".mp4")


@dataclass(frozen=True)
class InequalitySpec:
    """One ``[[inequalities]]`` table, its type and keys checked against the objective's class
    (:func:`uvms.tasks.objectives.check_table`); its values are checked by the objective when built on a model."""

    type: str
    keys: Mapping[str, Any]  # the table's other keys

    @property
    def table(self) -> dict[str, Any]:
        """The table as :func:`uvms.tasks.objectives.inequalities_from_table` takes it (``type`` included)."""
        return {"type": self.type, **self.keys}

    @property
    def files(self) -> list[str]:
        """The values of the keys that name a file (the objective's ``file_keys``)."""
        return [self.keys[name] for name in file_keys(self.type) if name in self.keys]


@dataclass(frozen=True, kw_only=True)
class ScenarioSpec:
    """A scenario file read and checked once (:func:`uvms.scenario.read_scenario`): one frozen section each.

    ``trajectory`` is None for a sequence scenario (``[[phases]]``); paths the file names (``model.path`` when it
    is a file, ``model.package_path``, ``plant.hydrodynamics``, the inequalities' files) are absolute.
    """

    path: Path  # the scenario file
    scenario: LabelSpec
    model: ModelSpec
    task: TaskSpec
    trajectory: TrajectorySpec | None
    solver: SolverSpec
    vehicle: VehicleSpec
    initial: InitialSpec
    simulation: SimulationSpec
    plant: PlantSpec
    vehicle_control: VehicleControlSpec
    controller: ControllerSpec
    excitation: ExcitationSpec
    outputs: OutputsSpec
    study: StudySpec
    phases: tuple[PhaseSpec, ...] = ()
    inequalities: tuple[InequalitySpec, ...] = field(default=())

    @property
    def controller_kind(self) -> str:
        """The controller that drives the run, from the file alone: a key of
        :data:`uvms.scenario.controllers.CONTROLLERS`. ``controller.type`` when it names one (``mpc``, or one
        registered); for ``solver`` the one the scenario needs: ``sequence`` ([[phases]]), ``excitation`` (thrusters
        driven open loop by excitation.wrench), ``actuated`` (plant.thrusters: the chain), ``gjm`` (a dynamic plant
        without thrusters: a passive vehicle) or ``tracking`` (the kinematic plant)."""
        if self.controller.type != "solver":
            return self.controller.type
        if self.phases:
            return "sequence"
        if self.plant.thrusters:
            return "excitation" if self.excitation.wrench else "actuated"
        return "tracking" if self.plant.type == "kinematic" else "gjm"

    @property
    def duration(self) -> float:
        """The simulated time [s] the scenario asks for, from its tables alone: ``simulation.duration``, else the sum
        of the phases' durations, else ``trajectory.duration`` (every trajectory type lasts that long)."""
        if self.simulation.duration:
            return float(self.simulation.duration)
        if self.phases:
            return float(sum(phase.duration for phase in self.phases))
        return float(self.trajectory.duration)

    def step_count(self) -> int:
        """The steps of simulation.dt over :attr:`duration`, checked before a run starts
        (:func:`uvms.numerics.integrate.step_count`).

        Raises:
            StepCountError: no step, or too many; the message names the keys.
        """
        if self.simulation.duration:
            duration_name = "simulation.duration"
        else:
            duration_name = "the phases' durations" if self.phases else "trajectory.duration"
        return step_count(self.duration, float(self.simulation.dt), dt_name="simulation.dt",
                          duration_name=duration_name)

    @property
    def name(self) -> str:
        """``scenario.name`` (the file's stem when not given)."""
        return self.scenario.name

    def named_files(self) -> list[str]:
        """The files the scenario names besides its model, absolute: the plant's hydrodynamics YAML and the
        inequalities' files (meshes, SRDF). What a run reads, which ``--watch`` watches and an output folder must
        not hold."""
        files = [self.plant.hydrodynamics] if self.plant.hydrodynamics else []
        return files + [name for table in self.inequalities for name in table.files]


def check_scenario(raw: Mapping, path: Path, controllers: Collection[str]) -> ScenarioSpec:
    """The spec of a raw scenario table (``path`` names it in messages): sections, keys, types and values checked,
    the defaults filled; paths as written. ``controllers``: the names of the registered controllers
    (:data:`uvms.scenario.controllers.CONTROLLERS`, built above the spec), which ``controller.type`` may name.

    Raises:
        ScenarioError: an unknown or missing section, an unknown key, a wrong type, an impossible value.
    """
    origin = str(path)
    sections = [*SECTIONS, *ARRAYS]
    unknown = sorted(set(raw) - set(sections))
    if unknown:
        raise ScenarioError(f"{origin}: unknown section(s) {', '.join(unknown)}; valid: {', '.join(sections)}")
    required = SEQUENCE_REQUIRED_SECTIONS if "phases" in raw else REQUIRED_SECTIONS
    missing = [section for section in required if section not in raw]
    if missing:
        raise ScenarioError(f"{origin}: missing section(s) {', '.join(missing)}")
    skipped = {"trajectory"} if "phases" in raw and "trajectory" not in raw else set()  # a sequence has none
    checked: dict[str, Any] = {name: None if name in skipped else cls.from_table(raw.get(name, {}), name, origin)
                               for name, cls in SECTIONS.items()}
    phases = raw.get("phases", [])
    if not isinstance(phases, list) or not all(isinstance(phase, dict) for phase in phases):
        raise ScenarioError(f"{origin}: phases must be an array of tables ([[phases]])")
    checked.update(phases=tuple(PhaseSpec.from_table(phase, f"phases[{index}]", origin)
                                for index, phase in enumerate(phases)),
                   inequalities=check_inequalities(raw.get("inequalities", []), origin))
    spec = ScenarioSpec(path=Path(path), **checked)
    check_controller(spec, origin, controllers)
    check_plant(spec, origin)
    check_initial(spec, origin)
    if spec.scenario.name:
        check_name("scenario.name", spec.scenario.name, origin, "it names the default output folder out/<name>",
                   example="hoang2011_w1")
    if spec.outputs.animation:
        check_name("outputs.animation", spec.outputs.animation, origin, "it names a file inside the output folder",
                   ANIMATION_SUFFIXES, example="grip.gif")
    return spec


def check_initial(spec: ScenarioSpec, origin: str) -> None:
    """``[initial]`` with what it needs of the other sections: ``fixed_base`` (a list of names) only to optimize q0,
    which needs the trajectory's start and orientation; a sequence scenario starts from the q0 given (its phases
    offset its frames from there) and takes one gain.

    Raises:
        ScenarioError: what does not go together, naming the file.
    """
    initial, trajectory = spec.initial, spec.trajectory
    fixed = initial.fixed_base
    if spec.phases and (initial.method != "given" or not isinstance(spec.solver.gain, NUMBER)):
        raise ScenarioError(f"{origin}: a sequence scenario needs initial.method = 'given' and one number for "
                            f"solver.gain")
    if initial.method == "given" and fixed:
        raise ScenarioError(f"{origin}: initial.fixed_base holds vehicle coordinates during the optimization of q0: it "
                            f"needs initial.method = 'optimize' (with 'given', initial.base is used as it is)")
    if not all(isinstance(name, str) for name in fixed):
        raise ScenarioError(f"{origin}: initial.fixed_base must be a list of vehicle coordinate names (e.g. "
                            f"['roll', 'pitch']), got {thaw(fixed)!r}")
    if initial.method == "optimize" and not spec.phases and not (trajectory.start and trajectory.orientation):
        raise ScenarioError(f"{origin}: initial.method = 'optimize' needs trajectory.start and trajectory.orientation")


def check_inequalities(tables: object, origin: str) -> tuple[InequalitySpec, ...]:
    """The ``[[inequalities]]`` tables of a scenario file, their types and keys checked (no model needed), every
    number finite and within the scenario's magnitude.

    Raises:
        ScenarioError: not an array of tables, or an unknown type or key (the message lists the valid ones).
    """
    if not isinstance(tables, list) or not all(isinstance(table, dict) for table in tables):
        raise ScenarioError(f"{origin}: inequalities must be an array of tables ([[inequalities]])")
    checked = []
    for index, table in enumerate(tables):
        try:
            type_name, keys = check_table(table, where=f"inequalities[{index}]")
        except UVMSError as exc:
            raise ScenarioError(f"{origin}: {exc}") from None
        check_range(f"inequalities[{index}]", table, origin)
        checked.append(InequalitySpec(type_name, dict(keys)))
    return tuple(checked)


def check_name(name: str, value: str, origin: str, role: str, suffixes: tuple[str, ...] = (), example: str = "") -> str:
    """A scenario string that becomes a file or folder name (``scenario.name`` -> ``out/<name>``,
    ``outputs.animation``): a plain name (:func:`uvms.io.names.is_plain_name`), with one of ``suffixes``."""
    plain = is_plain_name(value)
    suffix_ok = not suffixes or Path(value).suffix.lower() in suffixes
    if not (plain and suffix_ok):
        ending = f", ending in {' or '.join(suffixes)}" if suffixes else ""
        raise ScenarioError(f"{origin}: {name} = {value!r} is not valid: {role}, so it must be {NAME_RULE}{ending} "
                            f"(e.g. {example!r})")
    return value


def key_of(name: str) -> Key | None:
    """The :class:`~uvms.scenario.spec.keys.Key` of a dotted scenario key (``solver.damping``), None when no section
    declares it (a table's entry, ``model.args.l1``, or an inequality's key)."""
    section, _, item = name.partition(".")
    cls = PhaseSpec if section == "phases" else SECTIONS.get(section)
    return None if cls is None else cls.keys().get(item)
