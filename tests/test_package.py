"""The package's shape: layers as folders, imports only downward, no circle, small modules, a small top level.

The import graph is read from the source (every ``import`` and ``from ... import``, function-local ones too), so
these tests are how the closing numbers of the one-design issue are counted: ``pytest tests/test_package.py``.
Imports under ``if TYPE_CHECKING:`` name types for annotations only (they never run) and are not counted.
"""

from __future__ import annotations

import ast
import importlib
import importlib.util
import pkgutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import uvms

from conftest import ROOT, shipped

PACKAGE = Path(uvms.__file__).parent
#: The layers, lowest first: a module may import its own folder and the folders of lower rank only.
LAYERS = {
    "errors": 0, "numerics": 1, "io": 1, "robot": 2, "model": 3, "tasks": 4, "trajectory": 4, "dynamics": 4,
    "workspace": 4, "solvers": 5, "control": 6, "sim": 7, "viz": 8, "scenario": 9, "cli": 10, "": 11,
}
MAX_LINES = 400
MAX_TOP_LEVEL_NAMES = 22


def module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def import_graph() -> dict[str, set[str]]:
    """module -> the uvms modules it imports."""
    modules = {module_name(path): path for path in PACKAGE.rglob("*.py")}
    graph = {}
    for name, path in modules.items():
        package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
        imported = set()
        for node in runtime_nodes(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom):
                base = package.split(".")[:len(package.split(".")) - node.level + 1] if node.level else []
                target = ".".join(base + ([node.module] if node.module else []))
                for alias in node.names:
                    full = f"{target}.{alias.name}"
                    imported.add(full if full in modules else target)
            elif isinstance(node, ast.Import):
                imported.update(alias.name for alias in node.names)
        graph[name] = {target for target in imported if target in modules and target != name}
    return graph


def runtime_nodes(tree: ast.AST):
    """Every node of ``tree`` outside ``if TYPE_CHECKING:`` blocks."""
    for node in ast.iter_child_nodes(tree):
        if isinstance(node, ast.If) and getattr(node.test, "id", getattr(node.test, "attr", "")) == "TYPE_CHECKING":
            yield from (child for orelse in node.orelse for child in [orelse, *runtime_nodes(orelse)])
            continue
        yield node
        yield from runtime_nodes(node)


def layer(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on_stack, found, counter = {}, {}, [], set(), [], [0]

    def visit(node: str) -> None:
        index[node] = low[node] = counter[0]
        counter[0] += 1
        stack.append(node)
        on_stack.add(node)
        for target in graph[node]:
            if target not in index:
                visit(target)
                low[node] = min(low[node], low[target])
            elif target in on_stack:
                low[node] = min(low[node], index[target])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                component.append(member)
                if member == node:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for node in graph:
        if node not in index:
            visit(node)
    return found


#: Modules only an optional extra installs, that some of uvms's modules import at their top (the mpc extra).
OPTIONAL_MODULES = ("crocoddyl",)


def test_the_top_of_the_package_holds_only_the_entry_errors_and_folders():
    loose = sorted(path.name for path in PACKAGE.glob("*.py") if path.name not in ("__init__.py", "errors.py"))
    assert loose == []
    folders = {path.name for path in PACKAGE.iterdir() if path.is_dir() and not path.name.startswith("__")}
    assert folders == set(LAYERS) - {"", "errors"}


def test_no_module_is_above_400_lines():
    long = {module_name(path): n for path in PACKAGE.rglob("*.py")
            if (n := len(path.read_text().splitlines())) > MAX_LINES}
    assert long == {}


def test_imports_only_go_down_the_layers():
    upward = sorted(f"{source} -> {target}" for source, targets in import_graph().items() for target in targets
                    if layer(source) != layer(target) and LAYERS[layer(target)] >= LAYERS[layer(source)])
    assert upward == []


def test_there_is_no_import_circle():
    assert circles(import_graph()) == []


def test_the_circle_finder_finds_a_circle():
    assert circles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_no_module_is_hidden_behind_a_name_of_its_package():
    """``import uvms.x.y as m`` gives the module y, never a function its package exports under the same name."""
    hidden = []
    for info in pkgutil.walk_packages(uvms.__path__, "uvms."):
        if info.name.endswith("__main__"):
            continue
        parent, leaf = info.name.rsplit(".", 1)
        try:
            module = importlib.import_module(info.name)
        except ModuleNotFoundError as exc:  # a module of an extra that is not installed (the mpc extra's Crocoddyl)
            if exc.name not in OPTIONAL_MODULES:
                raise
            continue
        if getattr(importlib.import_module(parent), leaf, module) is not module:
            hidden.append(info.name)
    assert hidden == []


@pytest.mark.parametrize("name", sorted(uvms.__all__))
def test_every_top_level_name_is_importable(name):
    assert getattr(uvms, name) is not None


def test_the_top_level_is_small():
    assert len(uvms.__all__) <= MAX_TOP_LEVEL_NAMES
    assert "UVMSError" in uvms.__all__ and "load" in uvms.__all__


def test_one_result_type_and_no_old_paths():
    """One simulate, one result type; the module paths and names of before the layer folders are gone (no shims)."""
    from uvms.control import gjm
    from uvms.dynamics.plant import plant
    from uvms.sim.result import SimulationResult

    robot = shipped("hoang2011")
    result = uvms.simulate(uvms.Plant(robot), uvms.control.OpenLoop(arm=np.ones(robot.n_arm)), robot.neutral(),
                           0.1, 0.01)
    assert isinstance(result, SimulationResult) and result.plant.command.shape == (11, robot.n_arm)
    assert result.ee_position is None and result.arrays().keys() == {"t", "q", "v"}
    assert result.tracking is None and result.actuation is None
    assert result.integrator == "rk4" and not hasattr(result, "method")
    for module, name in ((plant, "simulate_plant"), (plant, "PlantResult"), (gjm, "simulate_gjm"), (gjm, "GJMResult"),
                         (uvms, "PlantResult"), (uvms, "GJMResult"), (uvms, "simulate_plant"), (uvms, "simulate_gjm"),
                         (uvms, "simulate_actuated"), (uvms, "actuation_metrics")):
        assert not hasattr(module, name), f"{module.__name__}.{name}"
    for old in ("uvms.plant", "uvms.plotting", "uvms.sandbox", "uvms.sweep", "uvms.moved", "uvms.sim.actuated",
                "uvms.sim.simulate", "uvms.control.station_keeping"):
        with pytest.raises(ModuleNotFoundError):
            importlib.import_module(old)
    with pytest.raises(TypeError):  # integrator is the one name of the choice
        uvms.simulate(uvms.Plant(robot), None, robot.neutral(), 0.1, 0.01, method="euler")


#: What ``ruff check`` reads (the rules and line length: pyproject.toml's [tool.ruff]).
RUFF_PATHS = ("uvms", "tests", "benchmarks", "docs", "notebooks/execute.py")


@pytest.mark.skipif(importlib.util.find_spec("ruff") is None, reason="ruff is not installed (pip install -e .[test])")
def test_ruff_is_clean():
    """Import order, unused names, line length: the rules of pyproject.toml hold on every file ruff reads."""
    done = subprocess.run([sys.executable, "-m", "ruff", "check", "--no-cache", *RUFF_PATHS], cwd=ROOT,
                          capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 0, done.stdout + done.stderr


def test_the_tests_mirror_the_package():
    """Every test folder is a folder of the package (the papers' checks and the fixtures aside), and a package folder
    made only of sub-folders (dynamics/) has its tests in the same sub-folders."""
    tests = PACKAGE.parent / "tests"
    folders = [path for path in tests.rglob("*") if path.is_dir() and "fixtures" not in path.parts
               and path.name != "__pycache__" and path.relative_to(tests).parts[0] != "papers"]
    assert folders and [path for path in folders if not (PACKAGE / path.relative_to(tests)).is_dir()] == []
    flat = [path.name for path in (tests / "dynamics").glob("test_*.py")]
    assert list((PACKAGE / "dynamics").glob("[!_]*.py")) == [] and flat == []
