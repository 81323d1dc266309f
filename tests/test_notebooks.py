"""The notebooks run, and what they show in the repository is what they print today.

Each notebook is executed once (as nbmake would) and its text outputs compared with the stored ones, cell by cell.
A failure names the notebook, the cell and the first differing line; `python notebooks/execute.py NAME` refreshes it.
"""

from __future__ import annotations

import importlib.util
import sys

import pytest

from conftest import ROOT

spec = importlib.util.spec_from_file_location("notebook_execute", ROOT / "notebooks" / "execute.py")
notebook_execute = importlib.util.module_from_spec(spec)
sys.modules["notebook_execute"] = notebook_execute  # dataclasses look their module up
spec.loader.exec_module(notebook_execute)

NOTEBOOKS = notebook_execute.notebook_paths()


missing_requirements = notebook_execute.missing_requirements


@pytest.fixture(autouse=True)
def inline_figures(monkeypatch):
    """The kernel draws inline figures: a headless MPLBACKEND (Agg, set by .ci/run) would hide them."""
    monkeypatch.delenv("MPLBACKEND", raising=False)


def test_every_notebook_is_found():
    assert {path.stem for path in NOTEBOOKS} >= {"hoang2011", "santos2006", "xiang2019", "amundsen2018", "tutorial",
                                                 "models", "mpc"}


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[path.stem for path in NOTEBOOKS])
def test_the_stored_outputs_are_current(path):
    missing = missing_requirements(path)
    if missing:
        pytest.skip(f"{path.name} needs {', '.join(missing)} (pip install 'uvms[mpc]')")
    stored = notebook_execute.nbformat.read(path, as_version=4)
    missing = notebook_execute.unexecuted(stored)
    assert not missing, (f"{path.name} is stored without outputs in cells {missing}: "
                         f"python notebooks/execute.py {path.stem}")
    fresh = notebook_execute.execute(path)  # raises CellExecutionError (with the traceback) if a cell fails
    stale = notebook_execute.differences(stored, fresh)
    assert not stale, (f"{path.name}: stored outputs are stale, {stale[0].first_line()} "
                       f"({len(stale)} cells); refresh: python notebooks/execute.py {path.stem}")
    assert sum("[figure]" in notebook_execute.cell_text(cell) for _, cell in notebook_execute.code_cells(stored)) == \
        sum("[figure]" in notebook_execute.cell_text(cell) for _, cell in notebook_execute.code_cells(fresh))


def test_a_notebook_that_needs_a_missing_module_is_skipped(tmp_path):
    assert missing_requirements(ROOT / "notebooks" / "mpc.ipynb") == [
        name for name in ("crocoddyl", "mim_solvers") if importlib.util.find_spec(name) is None]
    notebook = notebook_execute.nbformat.v4.new_notebook()
    notebook.metadata["uvms"] = {"requires": ["numpy", "no_such_module_for_uvms"]}
    path = tmp_path / "needs.ipynb"
    notebook_execute.nbformat.write(notebook, path)
    assert missing_requirements(path) == ["no_such_module_for_uvms"]


def copy_of(notebook):
    return notebook_execute.nbformat.reads(notebook_execute.nbformat.writes(notebook), as_version=4)


def first_stream(notebook):
    """(cell index, its first stream output) of the first executed code cell that prints."""
    for index, cell in notebook_execute.code_cells(notebook):
        for output in cell.outputs:
            if output["output_type"] == "stream":
                return index, output
    raise AssertionError("no printed output")


def test_a_changed_number_is_caught_and_a_temporary_path_is_not():
    stored = notebook_execute.nbformat.read(ROOT / "notebooks" / "amundsen2018.ipynb", as_version=4)
    assert notebook_execute.differences(stored, copy_of(stored)) == []
    one, other = copy_of(stored), copy_of(stored)
    first_stream(one)[1]["text"] += "written to /tmp/tmpabc123/out, object at 0x7f00deadbeef\n"
    first_stream(other)[1]["text"] += "written to /tmp/tmpxyz789/out, object at 0x7f11cafef00d\n"
    assert notebook_execute.differences(one, other) == []  # volatile parts masked
    one, other = copy_of(stored), copy_of(stored)
    first_stream(one)[1]["text"] += "residual 8.0e-14, drift 7.26e-10 m\n"
    first_stream(other)[1]["text"] += "residual 8.1e-14, drift 7.25e-10 m\n"
    assert notebook_execute.differences(one, other) == []  # rounding-level digits (they follow the CPU's BLAS)
    for small, grown in (("8.0e-14", "8.0e-04"), ("7.2e-10", "7.2e-09"), ("3.0e-12", "0.0030")):
        one, other = copy_of(stored), copy_of(stored)
        first_stream(one)[1]["text"] += f"residual {small}\n"
        first_stream(other)[1]["text"] += f"residual {grown}\n"
        assert len(notebook_execute.differences(one, other)) == 1, grown  # a number past 1e-9 is caught
    changed = copy_of(stored)
    index, stream = first_stream(changed)
    digit = next(ch for ch in stream["text"] if ch.isdigit())
    stream["text"] = stream["text"].replace(digit, str((int(digit) + 1) % 10), 1)
    found = notebook_execute.differences(stored, changed)
    assert [difference.cell for difference in found] == [index]
    assert found[0].first_line().startswith(f"cell {index}: stored ")


def test_the_tutorial_runs_when_copied_out_of_the_repository(tmp_path):
    """Shipped names, not ../ paths: a user's copy of the tutorial in any folder runs."""
    copy = tmp_path / "my_tutorial.ipynb"
    copy.write_text((ROOT / "notebooks" / "tutorial.ipynb").read_text())
    assert "../" not in "".join("".join(cell.source) for cell in notebook_execute.nbformat.read(copy, 4).cells)
    notebook_execute.execute(copy)  # raises CellExecutionError if a cell fails


def test_the_compile_notice_is_not_an_output():
    """A first solve slower than 2 s (numba compiling, or a loaded machine) says so on stderr; the note is not what
    the notebook shows, so it is not compared."""
    from uvms.io.progress import COMPILE_NOTICE

    cell = notebook_execute.nbformat.v4.new_code_cell("x = 1")
    cell.outputs = [notebook_execute.nbformat.v4.new_output("stream", name="stderr", text=COMPILE_NOTICE + "\n"),
                    notebook_execute.nbformat.v4.new_output("stream", name="stdout", text="1.5 m\n")]
    assert notebook_execute.cell_text(cell) == "[stdout] 1.5 m\n"
