"""The keys of a scenario section: what each accepts, its default, allowed values, bound and meaning, in one place.

A section is a frozen dataclass (:class:`Section`) whose fields are declared with :func:`key`; the field's
:class:`Key` is the one source of its type, default, allowed values, lower bound and meaning: the reader checks a
TOML table against it (:meth:`Section.from_table`) and the docs' scenario reference is generated from it.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, field, fields
from typing import Any, ClassVar

from ...errors import ScenarioError, UVMSError

NUMBER = (int, float)
NUMBERS = "numbers"  # a list of numbers
#: The default of a key the file must give.
REQUIRED: Any = type("Required", (), {"__repr__": lambda self: "REQUIRED"})()
#: The largest magnitude of a number in a scenario (SI units; model.args excepted, the model checks them). No gain
#: [1/s], damping, weight, length [m], speed [m/s], time [s] or angle [rad] of a vehicle-manipulator run comes near it,
#: and beyond it products such as damping**2, gain * dt or weight ratios overflow or swamp the solvers' doubles.
MAX_MAGNITUDE = 1e6


@dataclass(frozen=True)
class Bound:
    """A key's lowest value (besides ``|x| <= MAX_MAGNITUDE``): ``low``, excluded when ``strict``; ``what`` the key
    is, in the message of a value below it."""

    low: float
    strict: bool
    what: str


@dataclass(frozen=True)
class Key:
    """One key of a section: accepted types (a type, a tuple of types or :data:`NUMBERS`), default
    (:data:`REQUIRED`: none), allowed values (None: any), lower bound and meaning (Markdown, units in brackets)."""

    kinds: Any
    default: Any
    allowed: Collection | None
    doc: str
    bound: Bound | None = None

    @property
    def required(self) -> bool:
        return self.default is REQUIRED


def key(default: Any, kinds: Any, *, doc: str, allowed: Collection | None = None, bound: Bound | None = None) -> Any:
    """A section field: its :class:`Key` in the field's metadata, its default frozen (lists become tuples)."""
    spec = Key(kinds, freeze(default), allowed, doc, bound)
    metadata = {"key": spec}
    if default is REQUIRED:
        return field(metadata=metadata)
    if isinstance(default, dict):
        return field(default_factory=lambda: copy.deepcopy(default), metadata=metadata)
    return field(default=spec.default, metadata=metadata)


def thaw(value: Any) -> Any:
    """A spec value as the file wrote it (tuples as lists), for messages."""
    return [thaw(item) for item in value] if isinstance(value, tuple) else value


def freeze(value: Any) -> Any:
    """A checked value as a spec holds it: lists (and lists of lists) as tuples; tables copied."""
    if isinstance(value, (list, tuple)):
        return tuple(freeze(item) for item in value)
    return copy.deepcopy(value) if isinstance(value, dict) else value


class Section:
    """Base of the frozen dataclasses of a scenario's sections (fields declared with :func:`key`)."""

    ABOUT: ClassVar[str] = ""

    @classmethod
    def keys(cls) -> dict[str, Key]:
        """key -> :class:`Key`, in the order of the file's reference."""
        return {item.name: item.metadata["key"] for item in fields(cls) if "key" in item.metadata}

    @classmethod
    def from_table(cls, given: Any, name: str, origin: str) -> Section:
        """The section of the TOML table ``given`` (called ``name`` in messages, e.g. ``solver`` or ``phases[1]``),
        its keys checked, the defaults filled.

        Raises:
            ScenarioError: not a table, an unknown key (the valid ones listed), a required key missing, a value of
                the wrong type, not allowed or out of range.
        """
        if not isinstance(given, dict):
            raise ScenarioError(f"{origin}: [{name}] must be a table")
        keys = cls.keys()
        unknown = sorted(set(given) - set(keys))
        if unknown:
            raise ScenarioError(f"{origin}: unknown key(s) {', '.join(f'{name}.{k}' for k in unknown)}; "
                                f"valid in [{name}]: {', '.join(keys)}")
        values = {}
        for item, spec in keys.items():
            if item in given:
                values[item] = freeze(check_value(f"{name}.{item}", given[item], spec, origin))
            elif spec.required:
                raise ScenarioError(f"{origin}: {name}.{item} is required")
        return cls(**values)

    def changed(self, keys: Sequence[str] | None = None) -> list[str]:
        """The keys (all, or those of ``keys``) whose value differs from their default, in the section's order."""
        return [item for item, spec in self.keys().items()
                if (keys is None or item in keys) and getattr(self, item) != spec.default]


class SettingsSection(Section):
    """A section that writes a layer's settings object in the file (:attr:`SETTINGS`: its keys are the object's
    fields, by their names): the object is made once when the file is read, so that what it refuses is said there
    with the key's path, and the layer takes it whole (:attr:`settings`)."""

    SETTINGS: ClassVar[type]

    @classmethod
    def from_table(cls, given: Any, name: str, origin: str) -> Section:
        """The section (:meth:`Section.from_table`), its settings made once (each refusal of the layer begins with
        the field it is about)."""
        section = super().from_table(given, name, origin)
        try:
            section.settings  # noqa: B018 - the layer's settings check themselves
        except UVMSError as exc:
            raise ScenarioError(f"{origin}: {name}.{exc}") from None
        return section

    @property
    def settings(self) -> Any:
        """The layer's settings of this section: the one place the section becomes them."""
        return self.SETTINGS(**self.settings_values())

    def settings_values(self) -> dict[str, Any]:
        """The settings' fields from the section's keys of the same names."""
        return {name: getattr(self, name) for name in self.SETTINGS.names()}


def check_value(name: str, value: Any, spec: Key, origin: str) -> Any:
    """One value against its key's type, allowed set and range (:data:`MAX_MAGNITUDE`, its :class:`Bound`)."""
    kinds, allowed = spec.kinds, spec.allowed
    if kinds == NUMBERS:
        if not isinstance(value, list) or not all(is_number(v) for v in value):
            raise ScenarioError(f"{origin}: {name} must be a list of numbers, got {value!r}")
        check_range(name, value, origin, spec.bound)
        return [float(v) for v in value]
    kinds = kinds if isinstance(kinds, tuple) else (kinds,)
    if not isinstance(value, kinds) or (isinstance(value, bool) and bool not in kinds):
        raise ScenarioError(f"{origin}: {name} must be {type_names(kinds)}, got {value!r}")
    if isinstance(value, list) and kinds != (list,) and not all(is_number(v) for v in value):
        raise ScenarioError(f"{origin}: {name} must be {type_names(kinds)} of numbers, got {value!r}")
    if isinstance(value, dict) and list in kinds:  # a table in place of a list of numbers: {name = number}
        for item, entry in value.items():
            if not is_number(entry):
                raise ScenarioError(f"{origin}: {name}.{item} must be a number, got {entry!r}")
    if name != "model.args":  # xacro args are checked by the model (uvms.model.checks)
        check_range(name, value, origin, spec.bound)
    if allowed is not None and value not in allowed:
        raise ScenarioError(f"{origin}: {name} = {value!r} is not valid; valid: {', '.join(map(repr, allowed))}")
    return value


def is_number(value: Any) -> bool:
    return isinstance(value, NUMBER) and not isinstance(value, bool)


def check_range(name: str, value: Any, origin: str, bound: Bound | None = None) -> None:
    """Every number in ``value`` (a number, or lists and tables of them) finite, |x| <= MAX_MAGNITUDE, and above
    ``bound`` if given."""
    if isinstance(value, Mapping):
        for item, entry in value.items():
            check_range(f"{name}.{item}", entry, origin)
        return
    if isinstance(value, (list, tuple)):
        for entry in value:
            check_range(name, entry, origin, bound)
        return
    if not is_number(value):
        return
    shown = (f"{value:.6g}" if isinstance(value, float) or abs(value) < 10**15
             else f"a {len(str(abs(value)))}-digit integer")
    if not (isinstance(value, int) or math.isfinite(value)):
        raise ScenarioError(f"{origin}: {name} must be finite, got {value!r}")
    if abs(value) > MAX_MAGNITUDE:
        raise ScenarioError(f"{origin}: {name} = {shown} is out of range: scenario numbers are SI values with "
                            f"|x| <= {MAX_MAGNITUDE:.0e} (no gain, damping, weight, length, speed or time of a "
                            f"vehicle-manipulator run comes near it, and beyond it the solvers overflow)")
    if bound is not None and (value < bound.low or (bound.strict and value == bound.low)):
        raise ScenarioError(f"{origin}: {name} = {shown} is out of range: it is {bound.what}, valid: "
                            f"{bound.low:g} {'<' if bound.strict else '<='} {name} <= {MAX_MAGNITUDE:.0e}")


def type_names(kinds: tuple) -> str:
    names = {int: "a number", float: "a number", str: "a string", bool: "true/false", list: "a list", dict: "a table"}
    return " or ".join(dict.fromkeys(names[kind] for kind in kinds))
