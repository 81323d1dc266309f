"""Plain names: the one rule for a name read from a file (a scenario's, a model's robot, link, frame or thruster
name) before it becomes a file or folder name.

A plain name is one path component: it never leads outside the output folder (no ``/``, no ``..``) and never
hides (no leading ``.``). :func:`is_plain_name` checks the rule, :func:`plain_file_name` maps any text onto it
(a frame ``rexrov/ee`` becomes the file name ``rexrov_ee``), :func:`default_output_folder` refuses a name that
breaks it rather than guessing a folder.
"""

from __future__ import annotations

import re
from pathlib import Path

from ..errors import UVMSError

#: One path component of letters, digits, '.', '_' and '-', starting with a letter or a digit (and no "..").
NAME_PATTERN = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]{0,127}")
NAME_RULE = ("a plain name: letters, digits, '.', '_' and '-', starting with a letter or a digit, at most 128 "
             "characters, no '/' and no '..'")
#: The folder the commands write into when no ``--out`` is given (relative to the working folder).
DEFAULT_OUTPUT_ROOT = Path("out")


def is_plain_name(text: object) -> bool:
    """Whether ``text`` is a plain name (:data:`NAME_RULE`)."""
    return isinstance(text, str) and NAME_PATTERN.fullmatch(text) is not None and ".." not in text


def plain_file_name(text: str, fallback: str) -> str:
    """``text`` (a frame or scenario name) as a plain name: each run of other characters becomes ``_``, runs of
    dots one dot, leading ``._-`` dropped, at most 128 characters; ``rexrov/ee`` -> ``rexrov_ee``; ``fallback``
    when nothing is left."""
    name = re.sub(r"\.{2,}", ".", re.sub(r"[^A-Za-z0-9._-]+", "_", text)).lstrip("._-")[:128]
    return name or fallback


def default_output_folder(command: str, name: object, what: str = "the model's robot name") -> Path:
    """``out/<command>_<name>``: where a command writes without ``--out`` (``uvms identify``, ``uvms workspace``).

    A name from a file that is not a plain name is refused, never cleaned up into some other folder: a
    downloaded model named ``x/../../../important_run`` must not choose (or replace) a folder outside ``out/``,
    and a silently renamed folder would not be where the user looks.

    Args:
        command: the command's word ("identify", "workspace"), a plain name.
        name: the name read from the file (e.g. ``robot.name``).
        what: what ``name`` is, for the message.

    Raises:
        UVMSError: ``name`` is not a plain name (the message says to pass ``--out``).
    """
    if not is_plain_name(name):
        raise UVMSError(f"{what} {name!r} cannot name the output folder {DEFAULT_OUTPUT_ROOT}/{command}_<name>: it "
                        f"is not {NAME_RULE}; pass --out DIR")
    return DEFAULT_OUTPUT_ROOT / f"{command}_{name}"
