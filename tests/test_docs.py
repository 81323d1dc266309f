"""The examples in the docs run and say what they claim."""

from __future__ import annotations

import doctest
import re
import subprocess

import pytest

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


def test_readme_quickstart_is_two_commands_and_ci_runs_them_as_written():
    """CI (a fresh venv on a clean checkout) runs the README's block itself, so the two commands cannot drift."""
    text = (ROOT / "README.md").read_text()
    quickstart = text.split("## Quickstart", 1)[1].split("```bash\n", 1)[1].split("```", 1)[0]
    shell = subprocess.run(["bash", "-c", "awk '/^## Quickstart/{q=1} q && /^```bash/{b=1; next} b && /^```/{exit} b' "
                            "README.md"], cwd=ROOT, capture_output=True, text=True, check=True).stdout
    commands = [line for line in quickstart.splitlines() if line.strip()]
    assert shell.splitlines() == commands and len(commands) == 2
    assert commands[0].startswith("pip install -e") and "uvms run scenarios/" in commands[0]
    assert commands[1] == "python -m pytest"
    ci = (ROOT / ".ci" / "run").read_text()
    assert "awk '/^## Quickstart/{q=1} q && /^```bash/{b=1; next} b && /^```/{exit} b' README.md" in ci
    # a fresh venv, then the two commands as written, before CI installs anything else (extras, apt packages)
    first, second = (ci.index(f'bash -c "$(printf \'%s\\n\' "$quickstart" | sed -n {n}p)"') for n in (1, 2))
    assert ci.index('python3 -m venv "$venv"') < ci.index('. "$venv/bin/activate"') < first < second
    installs = [ci.index(word) for word in ("pip install", "apt-get install") if word in ci]
    assert installs and min(installs) > second


# ------------------------------------------------------------------ the documentation site (docs/)
DOCS = ROOT / "docs"
README_LIMIT = 15 * 1024  # [bytes] a README read in five minutes; the rest is in docs/


def test_readme_is_short_and_points_to_the_docs():
    text = (ROOT / "README.md").read_text()
    assert len(text.encode()) <= README_LIMIT, f"README.md is {len(text.encode())} bytes, over {README_LIMIT}"
    assert "python -m sphinx -W -b html docs docs/_build/html" in text
    assert not re.search(r"\bissue \d+", text), "the README speaks to users: no issue numbers"


def scenario_reference():
    """docs/_ext/scenario_reference.py, the generator of the scenario reference page."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("scenario_reference", DOCS / "_ext" / "scenario_reference.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_every_scenario_key_is_documented_and_every_documented_key_exists():
    reference = scenario_reference()
    schema, documented = reference.schema_keys(), reference.documented_keys()
    assert "model.path" in schema and "inequalities.plane_clearance.normal" in schema and "phases.offsets" in schema
    assert not schema - documented, \
        f"keys without a meaning (a spec field's doc, or scenario_keys.toml): {sorted(schema - documented)}"
    assert not documented - schema, f"documented keys the schema does not have: {sorted(documented - schema)}"
    meanings = reference.meanings()
    empty = [f"{section}.{key}" for section, table in meanings.items() for key, text in table.items()
             if isinstance(text, str) and not text.strip()]
    assert not empty


def test_scenario_reference_page_shows_every_section():
    shown = re.findall(r"```\{scenario-keys\} (\w+)", (DOCS / "scenarios.md").read_text())
    assert shown == scenario_reference().sections()


def test_scenario_reference_states_types_defaults_and_values_from_the_schema():
    from uvms.scenario.spec import SECTIONS

    markdown = scenario_reference().reference_markdown()
    assert "| `dt` | number | **required** |" in markdown
    assert '| `type` | string | `"circle"` | `"circle"`, `"line"`, `"pose"`, `"ramps"`, `"hold"` |' in markdown
    assert "| `bandwidth` | number or list | `[2.75, 2.75, 2.75, 5, 5, 5]` |" in markdown
    assert markdown.count("| `") >= sum(len(cls.keys()) for cls in SECTIONS.values())
    assert "| `dt` | number | **required** |  | integration step [s] |" in markdown  # the meaning from the spec


def docs_blocks(language: str) -> list[tuple[str, str]]:
    """(page, code) of every fenced block of a language in the docs' Markdown pages."""
    return [(str(page.relative_to(DOCS)), block) for page in sorted(DOCS.rglob("*.md")) if "_build" not in page.parts
            for block in re.findall(rf"```{language}\n(.*?)```", page.read_text(), flags=re.S)]


def minimal_scenario(source: str) -> str:
    """The one TOML block of the README or of the docs' *Bring your own ROV*."""
    if source == "README.md":
        blocks = re.findall(r"```toml\n(.*?)```", (ROOT / "README.md").read_text(), flags=re.S)
    else:
        blocks = [block for page, block in docs_blocks("toml") if page == source]
    assert len(blocks) == 1
    return blocks[0]


@pytest.mark.parametrize("source", ["README.md", "own_rov.md"])
def test_minimal_scenario_runs(tmp_path, source):
    scenario = tmp_path / "my_rov_line.toml"
    scenario.write_text(minimal_scenario(source))
    run = uvms.run_scenario(scenario, out=tmp_path / "out", overrides=["outputs.figures=false"], progress=False)
    assert 0 < run.metrics["max_position_error"] < 1e-4  # a 20 cm line; DLS damping 0.01 leaves micrometres


def test_docs_python_blocks_run(monkeypatch):
    monkeypatch.chdir(ROOT)
    blocks = docs_blocks("python")
    assert len(blocks) >= 3
    for page, block in blocks:
        exec(compile(block, f"docs/{page}", "exec"), {})  # noqa: S102 - our own docs


def test_docs_build_without_warnings(tmp_path):
    import importlib.util
    import subprocess
    import sys

    missing = [name for name in ("sphinx", "myst_nb", "furo") if importlib.util.find_spec(name) is None]
    if missing:
        pytest.skip(f"the docs extra is not installed ({', '.join(missing)}): pip install -e '.[docs]'")
    command = [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html", str(DOCS), str(tmp_path)]
    done = subprocess.run(command, capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert done.returncode == 0, done.stderr[-4000:]
    assert (tmp_path / "scenarios.html").read_text().count("<tr") > 100  # the generated scenario reference
    assert (tmp_path / "notebooks" / "hoang2011.html").exists()


def test_every_shipped_scenario_is_in_the_docs_table_once():
    """docs/scenarios.md's *Shipped scenarios* is the one list (scenarios/README.md points to it)."""
    table = (DOCS / "scenarios.md").read_text().split("## Shipped scenarios", 1)[1]
    listed = re.findall(r"`(\w+\.toml)`", table)
    assert sorted(listed) == sorted(path.name for path in (ROOT / "scenarios").glob("*.toml"))
