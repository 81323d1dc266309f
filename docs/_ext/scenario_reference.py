"""The scenario reference, generated: ``{scenario-keys} SECTION`` renders the keys of a section of a scenario file.

Types, defaults and allowed values come from :data:`uvms.scenario.schema.SCHEMA` (``[[phases]]``: ``PHASE_SCHEMA``;
``[[inequalities]]``: the objectives' constructors); the meaning of each key from ``reference/scenario_keys.toml``
beside this page. :func:`documented_keys` and :func:`schema_keys` are what tests/test_docs.py compares.
"""

from __future__ import annotations

import inspect
import math
from pathlib import Path

import tomllib
from docutils.parsers.rst import Directive
from docutils.statemachine import StringList

MEANINGS = Path(__file__).resolve().parents[1] / "reference" / "scenario_keys.toml"
#: the extra sections of a scenario file besides SCHEMA's: arrays of tables
ARRAYS = ("phases", "inequalities")


def meanings() -> dict:
    """The meanings table: section -> key -> Markdown text (``_about``: the section's introduction)."""
    with MEANINGS.open("rb") as file:
        return tomllib.load(file)


def inequality_keys() -> dict[str, dict[str, object]]:
    """type -> key -> default (``inspect.Parameter.empty`` when required) of each ``[[inequalities]]`` type."""
    from uvms.tasks.objectives import INEQUALITY_TYPES, table_keys

    result = {}
    for type_name, constructor in INEQUALITY_TYPES.items():
        parameters = inspect.signature(constructor).parameters
        result[type_name] = {key: parameters[key].default for key in table_keys(type_name)[0]}
    return result


def schema_keys() -> set[str]:
    """Every key a scenario file may hold, as ``section.key`` (inequalities: ``inequalities.TYPE.key``)."""
    from uvms.scenario.schema import PHASE_SCHEMA, SCHEMA

    keys = {f"{section}.{key}" for section, table in SCHEMA.items() for key in table}
    keys |= {f"phases.{key}" for key in PHASE_SCHEMA}
    keys |= {f"inequalities.{kind}.{key}" for kind, table in inequality_keys().items() for key in table}
    return keys


def documented_keys() -> set[str]:
    """Every key the meanings table explains, in the form of :func:`schema_keys` (common inequality keys expanded)."""
    table = meanings()
    keys = {f"{section}.{key}" for section, entries in table.items() if section != "inequalities"
            for key in entries if key != "_about"}
    inequalities = table["inequalities"]
    common = set(inequalities.get("common", {}))
    for kind, entries in inequality_keys().items():
        own = inequalities.get(kind, {})
        keys |= {f"inequalities.{kind}.{key}" for key in entries if key in own or key in common}
        keys |= {f"inequalities.{kind}.{key}" for key in own}
    return keys


def type_text(accepted: object) -> str:
    """The schema's accepted types, in words."""
    words = {str: "string", bool: "bool", int: "number", float: "number", list: "list", dict: "table",
             "numbers": "list of numbers"}
    kinds = accepted if isinstance(accepted, tuple) else (accepted,)
    names = []
    for kind in kinds:
        word = words.get(kind, getattr(kind, "__name__", str(kind)))
        if word not in names:
            names.append(word)
    return " or ".join(names)


def value_text(value: object) -> str:
    """A default or an allowed value as it is written in TOML."""
    from uvms.scenario.schema import REQUIRED

    if value is REQUIRED or value is inspect.Parameter.empty:
        return "**required**"
    if value is None:
        return "absent"
    if isinstance(value, bool):
        return f"`{str(value).lower()}`"
    if isinstance(value, str):
        return f'`"{value}"`'
    if isinstance(value, (list, tuple)):
        return "`[" + ", ".join(value_text(item).strip("`") for item in value) + "]`"
    if isinstance(value, dict):
        return "`{}`"
    if isinstance(value, float) and math.isinf(value):
        return "`inf`" if value > 0 else "`-inf`"
    return f"`{value:g}`" if isinstance(value, float) else f"`{value}`"


def cell(text: str) -> str:
    """Markdown table cell text (a pipe would end the cell)."""
    return text.replace("|", "\\|").replace("\n", " ")


def section_table(table: dict[str, tuple], about: dict[str, str]) -> list[str]:
    """Markdown lines of one section: its introduction and a table of its keys."""
    lines = [about.get("_about", ""), "",
             "| key | type | default | values | meaning |", "|---|---|---|---|---|"]
    for key, (accepted, default, allowed) in table.items():
        values = ", ".join(value_text(value) for value in allowed) if allowed else ""
        lines.append(f"| `{key}` | {type_text(accepted)} | {cell(value_text(default))} | {cell(values)} | "
                     f"{cell(about.get(key, ''))} |")
    return lines + [""]


def inequality_tables(about: dict) -> list[str]:
    """Markdown lines of ``[[inequalities]]``: one table per type."""
    lines = [about.get("_about", ""), ""]
    common = about.get("common", {})
    for kind, keys in inequality_keys().items():
        own = about.get(kind, {})
        lines += [f"**`type = \"{kind}\"`**", "", "| key | default | meaning |", "|---|---|---|"]
        lines += [f"| `{key}` | {cell(value_text(default))} | {cell(own.get(key, common.get(key, '')))} |"
                  for key, default in keys.items()]
        lines.append("")
    return lines


def sections() -> list[str]:
    """Every section of a scenario file, in the order of the reference: SCHEMA's, then the arrays of tables."""
    from uvms.scenario.schema import SCHEMA

    return [*SCHEMA, *ARRAYS]


def reference_markdown(section: str | None = None) -> str:
    """The reference of one section as Markdown (None: every section, in the order of :func:`sections`)."""
    from uvms.scenario.schema import PHASE_SCHEMA, SCHEMA

    if section is None:
        return "\n".join(reference_markdown(name) for name in sections())
    if section not in sections():
        raise ValueError(f"no scenario section {section!r}; sections: {', '.join(sections())}")
    about = meanings().get(section, {})
    if section == "inequalities":
        return "\n".join(inequality_tables(about))
    if section == "phases":
        return "\n".join(section_table(PHASE_SCHEMA, about))
    return "\n".join(section_table(SCHEMA[section], about))


class ScenarioKeys(Directive):
    """``{scenario-keys} SECTION``: the reference table(s) of a scenario section, parsed as Markdown in the page."""

    has_content = False
    required_arguments = 1

    def run(self) -> list:
        """The tables as nodes of the page."""
        from docutils import nodes

        node = nodes.container(classes=["scenario-reference"])
        self.state.nested_parse(StringList(reference_markdown(self.arguments[0]).splitlines(),
                                           source="scenario_keys.toml"),
                                self.content_offset, node)
        return [node]


def setup(app) -> dict:
    """Register the directive; the page is rebuilt whenever the meanings table changes."""
    app.add_directive("scenario-keys", ScenarioKeys)
    app.connect("env-get-outdated", lambda app, env, added, changed, removed: ["scenarios"])
    return {"parallel_read_safe": True, "version": "1"}
