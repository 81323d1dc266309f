"""What the CLI prints: every line with control characters escaped.

Names reach the terminal from files of strangers (scenario keys, model and frame names, grid values); an
escape sequence among them could write to the clipboard (OSC 52), erase lines or reorder text (bidirectional
overrides), so every line the CLI prints goes through :func:`say`.
"""

from __future__ import annotations

import re
import sys
from typing import TextIO

#: C0 controls, DEL, C1 controls, and the bidirectional embeddings, overrides and isolates.
UNPRINTABLE = re.compile("[\x00-\x1f\x7f-\x9f\u202a-\u202e\u2066-\u2069]")


def printable(text: str) -> str:
    """``text`` with every control character and bidi override escaped visibly (``\\x1b``, ``\\u202e``)."""
    return UNPRINTABLE.sub(lambda m: f"\\x{ord(m[0]):02x}" if ord(m[0]) < 0x100 else f"\\u{ord(m[0]):04x}", text)


def say(text: str, file: TextIO | None = None, *, lines: bool = False) -> None:
    """Print one line of the CLI (on stderr unless ``file``), escaped by :func:`printable`, and flush it.

    Args:
        text: what to print.
        file: the stream; None for stderr.
        lines: ``text`` is several lines (a table): each is escaped, the line breaks kept.
    """
    shown = "\n".join(printable(line) for line in text.split("\n")) if lines else printable(text)
    print(shown, file=file or sys.stderr, flush=True)
