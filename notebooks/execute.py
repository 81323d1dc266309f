"""Execute the notebooks and store them with their outputs, or check that the stored outputs are current.

The notebooks are committed executed (numbers and figures visible to someone browsing the repository). After a
change that moves a number, refresh them::

    python notebooks/execute.py                 # every notebook
    python notebooks/execute.py amundsen2018    # one

``tests/test_notebooks.py`` re-executes each notebook with the same functions and fails when a stored text output
differs from the fresh one (after masking what legitimately changes between runs: the repository's path, temporary
paths, object addresses, throughputs, the digits of numbers below 1e-9), so stale outputs cannot land. Cells tagged
``skip-execution`` (the browser viewer) are not run.
"""

from __future__ import annotations

import importlib.util
import os
import re
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import nbformat
from nbclient import NotebookClient

from uvms.io.progress import COMPILE_NOTICE

FOLDER = Path(__file__).resolve().parent
TIMEOUT = 900  # [s] per cell
#: What changes between two executions of the same notebook without any number changing.
VOLATILE = (
    (re.compile(r"/[^\s'\"()]*/(models|scenarios)/"), r"<repository>/\1/"),  # a shipped file, wherever the clone is
    (re.compile(r"/tmp/[^\s'\"),]+"), "<tmp>"),
    (re.compile(r"0x[0-9a-f]{6,}"), "<address>"),
    (re.compile(r"[\d.]+ ?[kM]? samples/s"), "<throughput>"),  # a timing: the machine's load, not the result
    (re.compile(r"\S+\.py:\d+: "), "<source>: "),  # where a warning was raised: moves with every edit
    # a number below 1e-9 printed in scientific notation (a residual, a drift, a converged error) is rounding: its
    # digits follow the CPU's BLAS kernels (8.0e-14 on one machine, 8.1e-14 on another); that it stays below 1e-9 is
    # what the cell shows, and a number that grows past it is still caught
    (re.compile(r"(?<![\w.])-?\d(?:\.\d+)?e-[1-9]\d\b"), "<below 1e-9>"),
)


@dataclass(frozen=True)
class Difference:
    """A code cell whose stored text output is not what a fresh execution prints."""

    cell: int
    stored: str
    fresh: str

    def first_line(self) -> str:
        """The first differing line, stored against fresh, for a one-line message."""
        stored, fresh = self.stored.splitlines(), self.fresh.splitlines()
        for index in range(max(len(stored), len(fresh))):
            old = stored[index] if index < len(stored) else "<nothing>"
            new = fresh[index] if index < len(fresh) else "<nothing>"
            if old != new:
                return f"cell {self.cell}: stored {old.strip()!r}, fresh {new.strip()!r}"
        return f"cell {self.cell}: outputs differ"


def notebook_paths(names: list[str] | None = None) -> list[Path]:
    """The notebooks of this folder, all or by name (with or without ``.ipynb``)."""
    every = sorted(FOLDER.glob("*.ipynb"))
    if not names:
        return every
    chosen = []
    for name in names:
        path = FOLDER / (name if name.endswith(".ipynb") else f"{name}.ipynb")
        if path not in every:
            raise SystemExit(f"no notebook {name!r}; valid: {', '.join(p.stem for p in every)}")
        chosen.append(path)
    return chosen


def missing_requirements(path: Path) -> list[str]:
    """The modules a notebook declares it needs (its metadata ``{"uvms": {"requires": [...]}}``, e.g. the mpc extra's
    crocoddyl) that are not installed: the notebook is skipped, not failed, without them."""
    requires = nbformat.read(path, as_version=4).metadata.get("uvms", {}).get("requires", [])
    return [name for name in requires if importlib.util.find_spec(name) is None]


def execute(path: Path) -> nbformat.NotebookNode:
    """A fresh execution of the notebook at ``path``, run from its folder (the file is not written)."""
    notebook = nbformat.read(path, as_version=4)
    NotebookClient(notebook, timeout=TIMEOUT, kernel_name="python3",
                   resources={"metadata": {"path": str(path.parent)}}).execute()
    return notebook


def cell_text(cell: nbformat.NotebookNode) -> str:
    """The text a code cell shows (streams, results, errors), volatile parts masked."""
    parts = []
    for output in cell.get("outputs", []):
        if output["output_type"] == "stream":  # the kernel splits a stream into chunks as it pleases: join them
            text = output["text"].replace(COMPILE_NOTICE + "\n", "")  # said when a first solve is slow: the load's
            if not text:
                continue
            if parts and parts[-1].startswith(f"[{output['name']}] "):
                parts[-1] += text
            else:
                parts.append(f"[{output['name']}] {text}")
        elif output["output_type"] == "error":
            parts.append(f"[error] {output['ename']}: {output['evalue']}")
        elif "text/plain" in output.get("data", {}) and "image/png" not in output["data"]:
            parts.append(f"[result] {output['data']['text/plain']}")
        elif "image/png" in output.get("data", {}):
            parts.append("[figure]")
    text = "\n".join(parts).replace(str(FOLDER.parent), "<repository>")  # the clone's own path
    for pattern, mask in VOLATILE:
        text = pattern.sub(mask, text)
    return text


def code_cells(notebook: nbformat.NotebookNode) -> list[tuple[int, nbformat.NotebookNode]]:
    """(index in the notebook, cell) of every code cell that is executed (not tagged skip-execution)."""
    return [(index, cell) for index, cell in enumerate(notebook.cells)
            if cell.cell_type == "code" and "skip-execution" not in cell.get("metadata", {}).get("tags", [])]


def differences(stored: nbformat.NotebookNode, fresh: nbformat.NotebookNode) -> list[Difference]:
    """The executed code cells whose stored text output differs from the fresh one."""
    found = []
    for (index, old), (_, new) in zip(code_cells(stored), code_cells(fresh)):
        if cell_text(old) != cell_text(new):
            found.append(Difference(index, cell_text(old), cell_text(new)))
    return found


def unexecuted(notebook: nbformat.NotebookNode) -> list[int]:
    """Indices of code cells stored without having been executed."""
    return [index for index, cell in code_cells(notebook) if cell.get("execution_count") is None]


def main(argv: list[str]) -> None:
    """Execute the named notebooks (all by default) and write them back with their outputs."""
    os.environ.pop("MPLBACKEND", None)  # the kernel draws inline figures; a headless Agg would store none
    for path in notebook_paths(argv):
        missing = missing_requirements(path)
        if missing:
            print(f"{path.name}: skipped, it needs {', '.join(missing)} (pip install 'uvms[mpc]')")
            continue
        started = time.perf_counter()
        notebook = execute(path)
        nbformat.write(notebook, path)
        print(f"{path.name}: executed and stored in {time.perf_counter() - started:.0f} s")


if __name__ == "__main__":
    main(sys.argv[1:])
