"""The base rule of ``uvms.load``: which vehicle base a model gets, and why (one line for ``uvms info``).

* a ``floating``/``planar`` joint at the root link is the vehicle, as written;
* a plain root link that carries mass (an ``<inertial>`` with mass > 0) is a vehicle: a free-flying
  joint ``ADDED_BASE_JOINT`` is added above it;
* a massless plain root link (``world``, an arm's mounting link) is a fixed base;
* ``base=`` overrides the last two ("fixed" holds a massive root link in the world), and may not
  contradict a root joint written in the file.
"""

from __future__ import annotations

from . import checks
from ..errors import BaseMismatchError, UVMSError

BASE_CHOICES = ("floating", "planar", "fixed")
#: Name given to a vehicle joint that uvms adds (base="floating"/"planar" on a plain root link).
ADDED_BASE_JOINT = "base_joint"


def choose_base(requested: str | None, tree: checks.TreeSummary, origin: str) -> str:
    """The base type to build (see :func:`decide_base`)."""
    return decide_base(requested, tree, origin)[0]


def decide_base(requested: str | None, tree: checks.TreeSummary, origin: str) -> tuple[str, str]:
    """The base type to build and why, by the rule of :func:`load`.

    Returns:
        (base type, reason): the reason is one line for ``uvms info``, e.g. "floating (added: the root
        link 'hull' carries 1810 kg; base='fixed' to hold it)".

    Raises:
        UVMSError: an unknown base name.
        BaseMismatchError: a base that contradicts the file's root joint.
    """
    if requested is not None and requested not in BASE_CHOICES:
        raise UVMSError(f"unknown base {requested!r}; valid: {', '.join(BASE_CHOICES)} or None (the rule of "
                        "uvms.load: the file's root joint, else floating when the root link carries mass)")
    root, mass = tree.root_link, tree.root_mass
    if tree.base_type != "fixed":
        if requested is not None and requested != tree.base_type:
            raise BaseMismatchError(
                f"{origin}: base={requested!r} contradicts the file, whose root joint {tree.base_joint!r} is "
                f"{tree.base_type}; use base={tree.base_type!r} or None, or edit the model"
            )
        return tree.base_type, f"{tree.base_type} (the file's root joint {tree.base_joint!r})"
    carried = f"the root link {root!r} carries {mass:.4g} kg" if mass > 0 else f"the root link {root!r} has no mass"
    if requested is None:
        if mass > 0:
            return "floating", f"floating (added: {carried}; base='fixed' to hold it)"
        return "fixed", f"fixed ({carried}; base='floating' or 'planar' to make it a vehicle)"
    if requested == "fixed":
        return "fixed", f"fixed (base='fixed'; {carried})"
    return requested, f"{requested} (added by base={requested!r} above the root link {root!r})"
