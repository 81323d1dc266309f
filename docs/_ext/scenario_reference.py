"""The scenario reference, generated: ``{scenario-keys} SECTION`` renders the keys of a section of a scenario file.

Types, defaults, allowed values and meanings come from the scenario spec, :mod:`uvms.scenario.spec` (each section a
frozen dataclass, each key a field whose :class:`~uvms.scenario.spec.keys.Key` says all of it; the section's
introduction its ``ABOUT``; ``[[phases]]``: ``PhaseSpec``). ``[[inequalities]]``: keys and defaults from the
objectives' constructors, their meanings from ``reference/scenario_keys.toml`` beside this page.
:func:`documented_keys` and :func:`schema_keys` are what tests/test_docs.py compares.
"""

from __future__ import annotations

import inspect
import math
from pathlib import Path

import tomllib
from docutils.parsers.rst import Directive
from docutils.statemachine import StringList

MEANINGS = Path(__file__).resolve().parents[1] / "reference" / "scenario_keys.toml"


def meanings() -> dict:
    """The meanings of the ``[[inequalities]]`` keys: ``{"inequalities": {"_about": ..., "common": {key: text},
    TYPE: {key: text}}}`` (Markdown)."""
    with MEANINGS.open("rb") as file:
        return tomllib.load(file)


def spec_class(section: str):
    """The spec dataclass of a section with a table of keys (``phases``: one ``[[phases]]`` table)."""
    from uvms.scenario.spec import SECTIONS, PhaseSpec

    return PhaseSpec if section == "phases" else SECTIONS[section]


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
    keys = {f"{section}.{key}" for section in sections() if section != "inequalities"
            for key in spec_class(section).keys()}
    keys |= {f"inequalities.{kind}.{key}" for kind, table in inequality_keys().items() for key in table}
    return keys


def documented_keys() -> set[str]:
    """Every key with a meaning (a spec field's ``doc``, or a line of the inequalities' meanings table), in the form
    of :func:`schema_keys` (common inequality keys expanded)."""
    keys = {f"{section}.{key}" for section in sections() if section != "inequalities"
            for key, spec in spec_class(section).keys().items() if spec.doc.strip()}
    inequalities = meanings()["inequalities"]
    common = set(inequalities.get("common", {}))
    for kind, entries in inequality_keys().items():
        own = inequalities.get(kind, {})
        keys |= {f"inequalities.{kind}.{key}" for key in entries if key in own or key in common}
        keys |= {f"inequalities.{kind}.{key}" for key in own}
    return keys


def type_text(accepted: object) -> str:
    """A key's accepted types, in words."""
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
    from uvms.scenario.spec import REQUIRED

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


def section_table(section: str) -> list[str]:
    """Markdown lines of one section: its introduction and a table of its keys."""
    cls = spec_class(section)
    lines = [cls.ABOUT, "", "| key | type | default | values | meaning |", "|---|---|---|---|---|"]
    for key, spec in cls.keys().items():
        values = ", ".join(value_text(value) for value in spec.allowed) if spec.allowed else ""
        lines.append(f"| `{key}` | {type_text(spec.kinds)} | {cell(value_text(spec.default))} | {cell(values)} | "
                     f"{cell(spec.doc)} |")
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
    """Every section of a scenario file, in the order of the reference: the spec's sections, then the arrays of
    tables."""
    from uvms.scenario.spec import ARRAYS, SECTIONS

    return [*SECTIONS, *ARRAYS]


def reference_markdown(section: str | None = None) -> str:
    """The reference of one section as Markdown (None: every section, in the order of :func:`sections`)."""
    if section is None:
        return "\n".join(reference_markdown(name) for name in sections())
    if section not in sections():
        raise ValueError(f"no scenario section {section!r}; sections: {', '.join(sections())}")
    if section == "inequalities":
        return "\n".join(inequality_tables(meanings()["inequalities"]))
    return "\n".join(section_table(section))


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
