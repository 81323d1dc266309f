"""Progress bars and the compile notice (uvms.io.progress): tqdm only for a bar that shows; one line while the
kernels compile."""

from __future__ import annotations

import sys
import types

from uvms.io import progress
from uvms.io.progress import COMPILE_NOTICE, compile_notice, progress_bar


class Stream:
    """stderr on a terminal or not."""

    def __init__(self, terminal: bool) -> None:
        self.terminal, self.text = terminal, ""

    def isatty(self) -> bool:
        return self.terminal

    def write(self, text: str) -> int:
        self.text += text
        return len(text)

    def flush(self) -> None:
        pass


def test_no_bar_is_made_when_none_would_show(monkeypatch):
    steps = range(3)
    monkeypatch.delitem(sys.modules, "IPython", raising=False)
    monkeypatch.setattr(sys, "stderr", Stream(terminal=False))
    assert progress_bar(steps, False) is steps and progress_bar(steps, None) is steps  # not on a terminal
    monkeypatch.setattr(sys, "stderr", Stream(terminal=True))
    assert progress_bar(steps, False) is steps
    shown = progress_bar(steps, None, desc="simulate")
    assert shown is not steps and list(shown) == [0, 1, 2] and "simulate" in sys.stderr.text
    assert list(progress_bar(steps, True)) == [0, 1, 2]


def test_the_tqdm_class_is_tqdm_autos():
    from tqdm.auto import tqdm

    assert progress.tqdm is tqdm


def test_the_compile_notice_says_one_line_once_numba_runs_past_its_delay(monkeypatch):
    monkeypatch.setitem(sys.modules, "numba", sys.modules.get("numba", types.ModuleType("numba")))
    monkeypatch.delitem(sys.modules, "tqdm", raising=False)  # no bar on the terminal: a plain line
    monkeypatch.setattr(sys, "stderr", Stream(terminal=False))
    timer = compile_notice(after=0.01)
    timer.join(5.0)
    assert sys.stderr.text == COMPILE_NOTICE + "\n"
    early = compile_notice(after=5.0)  # a first solve that ended in time (cancelled) says nothing
    early.cancel()
    early.join(5.0)
    monkeypatch.delitem(sys.modules, "numba")  # a solver without kernels says nothing either
    late = compile_notice(after=0.01)
    late.join(5.0)
    assert sys.stderr.text == COMPILE_NOTICE + "\n" and not early.is_alive() and not late.is_alive()


def test_a_terminal_that_reports_no_width_still_gets_a_bar(monkeypatch):
    """A pty never sized (``script``, some CI terminals) reports 0 columns: tqdm alone draws an empty line there."""
    import os

    leader, follower = os.openpty()  # a new pty: 0 columns, 0 rows
    try:
        assert os.get_terminal_size(follower).columns == 0
        with os.fdopen(os.dup(follower), "w") as terminal:
            monkeypatch.setattr(sys, "stderr", terminal)
            assert list(progress_bar(range(5), None, desc="simulate", mininterval=0)) == list(range(5))
            terminal.flush()
        shown = os.read(leader, 65536).decode()
    finally:
        os.close(leader)
        os.close(follower)
    assert "simulate:" in shown and "/5 [" in shown and "%|" in shown
