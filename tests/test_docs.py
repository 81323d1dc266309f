"""The examples in the docs run and say what they claim."""

from __future__ import annotations

import doctest
import re

import uvms

from conftest import ROOT


def test_package_docstring_example():
    result = doctest.testmod(uvms, verbose=False)
    assert result.attempted >= 3 and result.failed == 0


def test_readme_python_example_runs(monkeypatch):
    monkeypatch.chdir(ROOT)
    blocks = re.findall(r"```python\n(.*?)```", (ROOT / "README.md").read_text(), flags=re.S)
    assert blocks
    namespace: dict = {}
    exec(compile(blocks[0], "README.md", "exec"), namespace)  # noqa: S102 - our own README
    assert namespace["J"].shape == (6, 6) and namespace["G"].shape == (6, 3)
    # Alpha 5 (5) + panda (7 arm joints, finger 1; finger 2 mimics finger 1 and adds no degree of freedom)
    assert namespace["rov_panda"].n_arm == 5 + 8


def test_readme_quickstart_is_two_commands():
    text = (ROOT / "README.md").read_text()
    quickstart = text.split("## Quickstart", 1)[1].split("```bash\n", 1)[1].split("```", 1)[0]
    commands = [line for line in quickstart.splitlines() if line.strip()]
    assert len(commands) == 2
    assert "python -m pytest" in commands[1]
    assert "python -m pytest" in (ROOT / ".ci" / "run").read_text()
