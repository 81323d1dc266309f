"""The progress bar of long computations: ``tqdm.auto``, imported when a bar is shown, once and quietly.

``tqdm.auto`` warns in a notebook without ipywidgets and then falls back to a text bar; that warning says
nothing a user can act on, so it is silenced here, in one place. tqdm and the inter-process lock its first bar
creates cost 30-70 ms: :func:`progress_bar` does not import it when no bar would show (``--quiet``, output not on
a terminal), and ``tqdm`` itself is imported at its first use (``from uvms.io.progress import tqdm``).
"""

from __future__ import annotations

import os
import sys
import threading
import warnings
from collections.abc import Iterable, Iterator
from typing import Any, TypeVar

__all__ = ["COMPILE_NOTICE", "compile_notice", "progress_bar", "tqdm"]  # noqa: F822 (tqdm: the module's __getattr__)

#: What a first solve slower than :data:`COMPILE_NOTICE_AFTER` says: numba compiles the kernels at their first call.
COMPILE_NOTICE = ("uvms: note: compiling the solvers' kernels for this machine (numba: about 10-45 s, once after an "
                  "install or an upgrade; later runs load them from its cache)")
COMPILE_NOTICE_AFTER = 2.0  # [s]
#: (columns, lines) of a terminal that reports no size.
DEFAULT_SIZE = (80, 24)

Item = TypeVar("Item")


def progress_bar(iterable: Iterable[Item], progress: bool | None, **options: Any) -> Iterator[Item] | Iterable[Item]:
    """``iterable`` with a tqdm bar (``options``: desc, unit, leave...), or as it is when no bar would show.

    Args:
        progress: True: a bar; False: none; None: tqdm's rule, a bar on a terminal or in a notebook.
    """
    if progress is False or (progress is None and not _terminal_or_notebook()):
        return iterable
    size = _terminal_size()
    if size is not None and 0 in size:  # a pty never sized (script, some CI terminals): tqdm would draw nothing
        options = {"ncols": size[0] or DEFAULT_SIZE[0], "nrows": size[1] or DEFAULT_SIZE[1], **options}
    return _tqdm()(iterable, disable=None if progress is None else False, **options)


def _terminal_size() -> tuple[int, int] | None:
    """(columns, lines) stderr's terminal reports (0 for a pty whose size was never set), None if not a terminal."""
    try:
        return tuple(os.get_terminal_size(sys.stderr.fileno()))
    except (AttributeError, OSError, ValueError):  # not a terminal, or a stream without a file descriptor
        return None


def _terminal_or_notebook() -> bool:
    """Whether tqdm would show a bar with disable=None: stderr is a terminal, or IPython runs (a notebook's bar)."""
    isatty = getattr(sys.stderr, "isatty", None)
    return bool(isatty is not None and isatty()) or "IPython" in sys.modules


def compile_notice(after: float = COMPILE_NOTICE_AFTER) -> threading.Timer:
    """A started timer that prints :data:`COMPILE_NOTICE` on stderr after ``after`` [s] if numba is loaded by then.

    Start it before a solver's first call and cancel it after: the kernels (:mod:`uvms.numerics._kernels`) compile
    at their first call after an install, several seconds in which nothing else would be said; a call that
    loads them from numba's cache, or a solver without kernels, ends before ``after`` and says nothing.
    """

    def say() -> None:
        if "numba" not in sys.modules:
            return
        bars = sys.modules.get("tqdm")
        if bars is not None:  # a bar may be on the terminal: tqdm clears it, prints the line and draws it again
            bars.tqdm.write(COMPILE_NOTICE, file=sys.stderr)
        else:
            print(COMPILE_NOTICE, file=sys.stderr, flush=True)

    timer = threading.Timer(after, say)
    timer.daemon = True  # never keeps the process alive
    timer.start()
    return timer


def _tqdm() -> Any:
    """The class ``tqdm.auto.tqdm`` (imported at the first call, its notebook warning silenced)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        from tqdm.auto import tqdm

    return tqdm


def __getattr__(name: str) -> Any:
    """``tqdm`` (the class of ``tqdm.auto``), imported at its first use (PEP 562)."""
    if name != "tqdm":
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    bar_class = globals()["tqdm"] = _tqdm()
    return bar_class
