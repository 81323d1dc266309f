"""The solvers the one-call entries build, kept for the next call with the same inputs.

``clik_velocity`` / ``clik_step`` and ``set_based_velocity`` / ``set_based_step`` check their inputs and
prepare their pieces in a solver object (:class:`~uvms.solvers.clik.CLIKSolver`,
:class:`~uvms.solvers.set_based.SetBasedSolver`), which a loop may build once itself. A loop that calls the
functions instead, step after step with the same robot, tasks and options (the ordinary way to write one in
a notebook), gets the solver of its previous call back from here: the same numbers, without the checks
and preparation at every step.

A solver is found again by the *values* of its array and number inputs and the *identity* of its objects
(robot, tasks, objectives, potential, limits): an array changed in place is a new key, and a task whose
target changes is the same task (solvers read targets at every call), while an objective's or a limit's
settings are read when the solver is built (make a new object to change them, as for a solver built by
hand). The cache holds the objects of its keys, so no object of a key can be freed and its id reused while
the entry lives.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Callable
from typing import TypeVar

import numpy as np

Solver = TypeVar("Solver")

#: Entries kept (least recently used dropped first): a few loops side by side.
SIZE = 8
#: Plain values keyed by themselves (and their type: 1, 1.0 and True are three keys).
SCALARS = frozenset((bool, int, float, str, type(None)))


class Unkeyable(Exception):
    """An input that cannot be keyed (an iterator, which a key would consume): the solver is built afresh."""


def key_of(value: object, held: list) -> object:
    """A hashable key of one input; objects are keyed by id and appended to ``held`` (kept alive with the entry).

    Raises:
        Unkeyable: an iterator or generator.
    """
    kind = type(value)
    form = FORMS.get(kind)
    if form is None:
        form = FORMS[kind] = form_of(kind)
    if form == "plain":
        return (kind, value)
    if form == "object":
        held.append(value)
        return ("object", id(value))
    if form == "array":
        return ("array", value.dtype.str, value.shape, value.tobytes())
    if form == "sequence":
        return (kind, tuple([key_of(item, held) for item in value]))
    if form == "scalar":
        return ("scalar", value.dtype.str, value.item())
    if form == "iterator":  # a key would consume it
        raise Unkeyable
    try:  # a value object (a VariableDamping): the same numbers are the same key
        return ("value", kind, hash(value), value)
    except TypeError:  # a field that is not hashable (an array): by identity
        held.append(value)
        return ("object", id(value))


def form_of(kind: type) -> str:
    """How :func:`key_of` keys the values of a type (read once per type: a loop's inputs repeat their types)."""
    if kind in SCALARS:
        return "plain"
    if kind is np.ndarray:
        return "array"
    if kind is list or kind is tuple:
        return "sequence"
    if issubclass(kind, np.generic):
        return "scalar"
    if hasattr(kind, "__next__"):
        return "iterator"
    params = getattr(kind, "__dataclass_params__", None)
    return "value" if params is not None and params.frozen and params.eq else "object"


#: The form of each type met (:func:`form_of`).
FORMS: dict[type, str] = {}


class PreparedSolvers:
    """The last ``SIZE`` solvers built, by the key of their inputs."""

    def __init__(self, size: int = SIZE) -> None:
        self.size = size
        self._entries: OrderedDict[tuple, tuple[object, list]] = OrderedDict()

    def get(self, kind: str, build: Callable[[], Solver], *inputs: object) -> Solver:
        """The solver of this ``kind`` and ``inputs`` built before, or ``build()`` (kept when its inputs can be keyed).

        ``build`` raises what the solver refuses; nothing is kept then.
        """
        held: list = []
        try:
            key = (kind, key_of(inputs, held))
        except Unkeyable:
            return build()
        entry = self._entries.get(key)
        if entry is not None:
            try:
                self._entries.move_to_end(key)
            except KeyError:  # dropped meanwhile by another thread: the solver still serves
                pass
            return entry[0]
        solver = build()
        self._entries[key] = (solver, held)
        while len(self._entries) > self.size:
            try:
                self._entries.popitem(last=False)
            except KeyError:
                pass
        return solver

    def clear(self) -> None:
        """Forget every solver (and release the objects of their keys)."""
        self._entries.clear()


#: The one cache of the one-call entries.
PREPARED = PreparedSolvers()
