"""Sphinx configuration of the uvms documentation: ``python -m sphinx -W -b html docs docs/_build/html``."""

from __future__ import annotations

import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
sys.path.insert(0, str(DOCS.parent))  # the uvms of this checkout, as the tests import it
sys.path.insert(0, str(DOCS / "_ext"))

project = "uvms"
author = "the uvms authors"
copyright = "the uvms authors, BSD-3-Clause"  # noqa: A001 - Sphinx's name

extensions = [
    "myst_nb",  # Markdown pages (myst-parser) and the stored, executed notebooks
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "scenario_reference",  # the scenario reference, generated from the typed spec uvms.scenario.spec
]
source_suffix = {".md": "myst-nb", ".ipynb": "myst-nb"}
exclude_patterns = ["_build", "notebooks/execute.py", "notebooks/.ipynb_checkpoints"]
root_doc = "index"

# the notebooks are stored executed and re-executed by tests/test_notebooks.py: render their outputs as stored
nb_execution_mode = "off"
nb_merge_streams = True
myst_enable_extensions = ["colon_fence", "dollarmath", "deflist"]
myst_heading_anchors = 3

autodoc_default_options = {"members": True, "show-inheritance": True}
autodoc_member_order = "bysource"
autodoc_typehints = "description"
autosummary_generate = False
napoleon_google_docstring = True
napoleon_numpy_docstring = False
napoleon_use_rtype = False

html_theme = "furo"
html_title = "uvms"
