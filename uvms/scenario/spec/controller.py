"""The ``[controller]`` section: what drives the run, the ``[solver]``'s controller or the whole-body MPC, and the
MPC's settings.

The MPC's keys are :class:`uvms.control.mpc.settings.MPCSettings`' fields, generated here and listed nowhere else:
their types and defaults from the dataclass, their meanings from its docstring's ``Attributes:`` (one entry per
field, or ``a, b: text`` for several), their allowed values from the settings module's ``SOLVERS`` and
``INTEGRATORS``, their ranges checked by ``MPCSettings`` itself. No Crocoddyl is needed to read or check the section.
"""

from __future__ import annotations

import re
import typing
from collections.abc import Collection
from dataclasses import fields, make_dataclass
from typing import Any, ClassVar

from ...control.mpc import settings as mpc_settings
from ...control.mpc.settings import MPCSettings
from ...errors import ScenarioError, UVMSError
from .keys import NUMBER, Section, key

#: The controllers ``controller.type = "solver"`` leaves to the scenario (:attr:`ScenarioSpec.controller_kind
#: <uvms.scenario.spec.ScenarioSpec.controller_kind>`): kinematic tracking, the GJM controller of a passive vehicle, the
#: actuated chain, an open-loop excitation, a [[phases]] sequence. Every other controller of the registry
#: (:data:`uvms.scenario.controllers.CONTROLLERS`: the MPC, one registered later) is a ``controller.type`` value.
CHOSEN_CONTROLLERS = ("tracking", "gjm", "actuated", "excitation", "sequence")
#: The scenario's kinds of an MPCSettings field's type.
KINDS = {int: int, float: NUMBER, str: str, bool: bool}
#: The allowed values of the MPC's string settings.
ALLOWED = {"solver": mpc_settings.SOLVERS, "integrator": mpc_settings.INTEGRATORS}
#: The task axes the MPC tracks: the end effector's position (its cost is the frame's translation error).
MPC_AXES = ("x", "y", "z")


def settings_docs(cls: type = MPCSettings) -> dict[str, str]:
    """field -> its meaning, from the ``Attributes:`` section of ``cls``'s Google-style docstring.

    An entry is ``name: text`` or ``name, other: text`` (both get the text), continued on deeper-indented lines; a
    line may hold two entries separated by ``; other_name: `` when ``other_name`` is a field.
    """
    names = {item.name for item in fields(cls)}
    text = (cls.__doc__ or "").split("Attributes:", 1)[-1]
    entries: list[str] = []
    for line in text.splitlines():
        stripped = line.strip()
        if not stripped:
            continue
        head = stripped.split(":", 1)[0]
        if ":" in stripped and all(name.strip() in names for name in head.split(",")):
            entries.append(stripped)
        elif entries:
            entries[-1] += " " + stripped
    docs: dict[str, str] = {}
    separator = re.compile(r";\s+(?=(?:\w+, )*\w+: )")
    for entry in entries:
        last = ""
        for part in separator.split(entry):
            head, _, body = part.partition(":")
            targets = [name.strip() for name in head.split(",")]
            if all(name in names for name in targets):
                docs.update(dict.fromkeys(targets, body.strip()))
                last = targets[-1]
            else:  # "; word: ..." inside a meaning: it goes on
                docs[last] = f"{docs[last]}; {part}"
    return docs


def mpc_fields() -> list[tuple[str, Any, Any]]:
    """(name, type, key) of every MPCSettings field, as :func:`dataclasses.make_dataclass` takes them."""
    types, docs = typing.get_type_hints(MPCSettings), settings_docs()
    made = []
    for item in fields(MPCSettings):
        kind = types[item.name]
        if kind not in KINDS:
            raise TypeError(f"MPCSettings.{item.name}: a {kind} has no scenario kind (int, float, str, bool)")
        meaning = docs.get(item.name, "").replace("``", "`")  # reST literals as Markdown's
        doc = f"`mpc`: {meaning}" if meaning else ""
        made.append((item.name, kind, key(item.default, KINDS[kind], doc=doc, allowed=ALLOWED.get(item.name))))
    return made


#: The MPC's keys of [controller] (every MPCSettings field).
MPC_KEYS = tuple(item.name for item in fields(MPCSettings))


class ControllerSection(Section):
    """The methods of :class:`ControllerSpec` (its fields are made from MPCSettings')."""

    ABOUT: ClassVar[str] = (
        "What drives the run: the `[solver]`'s method in the controller the plant needs (the default), or the "
        "whole-body model-predictive controller on Crocoddyl (`type = \"mpc\"`; `pip install 'uvms[mpc]'`). The "
        "MPC needs `plant.type = \"hydrodynamic\"` with `plant.thrusters = true` and `task.axes = [\"x\", \"y\", "
        "\"z\"]`; it plans the thrusts and the arm's servo commands over its horizon from the measured state, the "
        "end effector along the trajectory, the `[[inequalities]]` as the problem's constraints (`csqp`) or "
        "penalties (`box_fddp`). `[solver]` and `[vehicle_control]` are not used by it. See *Whole-body MPC* in the "
        "user guide.")

    @classmethod
    def from_table(cls, given: Any, name: str, origin: str) -> Section:
        """The section (:meth:`Section.from_table`), the MPC's values checked by :class:`MPCSettings` (what the
        type needs of them: :func:`check_controller`)."""
        section = super().from_table(given, name, origin)
        try:
            section.settings  # noqa: B018 - MPCSettings checks the values
        except UVMSError as exc:
            raise ScenarioError(f"{origin}: [{name}] {exc}") from None
        return section

    @property
    def settings(self) -> MPCSettings:
        """The MPC's settings of this section (floats as floats)."""
        types = typing.get_type_hints(MPCSettings)
        return MPCSettings(**{name: float(getattr(self, name)) if types[name] is float else getattr(self, name)
                              for name in MPC_KEYS})


ControllerSpec = make_dataclass(
    "ControllerSpec",
    [("type", str, key("solver", str,
                       doc="`solver`: the `[solver]`'s method in the controller the plant needs (kinematic tracking; "
                           "the GJM controller of a passive vehicle; the actuated chain with thrusters); `mpc`: the "
                           "whole-body MPC (the keys below); or the name of a controller registered in "
                           "`uvms.scenario.controllers.CONTROLLERS`")),
     *mpc_fields()],
    bases=(ControllerSection,), frozen=True, kw_only=True)
ControllerSpec.__module__ = __name__
ControllerSpec.__doc__ = "The ``[controller]`` section of a scenario, checked (fields: ``type`` and MPCSettings')."


def controller_types(controllers: Collection[str]) -> tuple[str, ...]:
    """The values of controller.type given the registry's ``controllers``: ``solver`` (the one the scenario
    chooses), then every other controller of the registry."""
    return ("solver", *(name for name in controllers if name not in CHOSEN_CONTROLLERS))


def check_controller(spec: Any, origin: str, controllers: Collection[str]) -> None:
    """Refuse a controller.type that is not one of ``controllers`` (:func:`controller_types`), the MPC's keys on
    another controller, and an MPC on a run it cannot drive (one line each: why, and what works).

    Raises:
        ScenarioError: an unknown ``controller.type`` (the message lists the valid ones); an MPC key without
            ``controller.type = "mpc"``; ``controller.type = "mpc"`` without the actuated hydrodynamic plant, with an
            open-loop excitation, task axes other than the position, or a control period that is not a multiple of
            ``simulation.dt``.
    """
    controller, plant = spec.controller, spec.plant
    valid = controller_types(controllers)
    if controller.type not in valid:
        raise ScenarioError(f"{origin}: controller.type = {controller.type!r} is not valid; valid: "
                            f"{', '.join(map(repr, valid))}")
    if controller.type != "mpc":
        given_keys = controller.changed(MPC_KEYS)
        if given_keys:
            raise ScenarioError(f"{origin}: controller.{given_keys[0]} is a setting of the MPC; it needs "
                                f"controller.type = 'mpc' (got {controller.type!r})")
        return
    if plant.type != "hydrodynamic" or not plant.thrusters:
        raise ScenarioError(f"{origin}: controller.type = 'mpc' commands the thrusters and the arm's servos: it needs "
                            f"plant.type = 'hydrodynamic' and plant.thrusters = true, got plant.type = "
                            f"{plant.type!r} and plant.thrusters = {str(plant.thrusters).lower()}")
    if spec.excitation.wrench:
        raise ScenarioError(f"{origin}: excitation.wrench drives the thrusters open loop; it cannot run with "
                            f"controller.type = 'mpc' (remove one)")
    if tuple(sorted(spec.task.axes)) != MPC_AXES:
        shown = list(spec.task.axes) or "all six"
        raise ScenarioError(f"{origin}: controller.type = 'mpc' tracks the end effector's position: it needs "
                            f"task.axes = ['x', 'y', 'z'], got {shown}")
    period, dt = float(controller.control_period), float(spec.simulation.dt)
    ratio = period / dt
    if period > 0 and (ratio < 1 - 1e-9 or abs(ratio - round(ratio)) > 1e-6):
        raise ScenarioError(f"{origin}: controller.control_period must be 0 (a solve at every step) or a multiple of "
                            f"simulation.dt = {dt:g} s, got {period:g}")


__all__ = ["CHOSEN_CONTROLLERS", "ControllerSpec", "MPC_KEYS", "check_controller", "controller_types", "settings_docs"]
