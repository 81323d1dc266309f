"""Import paths of the modules that moved into the layer folders, kept working for one release.

``import uvms.plant`` (or ``from uvms import plant``) gives the very module ``uvms.dynamics.plant``, with a
``DeprecationWarning`` naming the new path: monkeypatching through either name patches the same module.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys
import warnings

#: old module -> new module
MOVED = {
    "uvms.checks": "uvms.model.checks",
    "uvms.resources": "uvms.model.resources",
    "uvms.sandbox": "uvms.model.sandbox",
    "uvms.compose": "uvms.model.compose",
    "uvms.plant": "uvms.dynamics.plant",
    "uvms.hydrodynamics": "uvms.dynamics.hydrodynamics",
    "uvms.gjm_control": "uvms.control.gjm",
    "uvms.sequence": "uvms.control.sequence",
    "uvms.plotting": "uvms.viz.plotting",
    "uvms.drawing": "uvms.viz.drawing",
    "uvms.viewer": "uvms.viz.viewer",
    "uvms.teach": "uvms.viz.teach",
    "uvms.sweep": "uvms.scenario.sweep",
}


class MovedModuleFinder(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Resolves an old module name to the module at its new place (the same object)."""

    def find_spec(self, name, path=None, target=None):  # noqa: D102 - importlib API
        return importlib.util.spec_from_loader(name, self) if name in MOVED else None

    def create_module(self, spec):  # noqa: D102 - importlib API
        warnings.warn(f"{spec.name} moved to {MOVED[spec.name]}; the old name goes away in the next release",
                      DeprecationWarning, stacklevel=2)
        return importlib.import_module(MOVED[spec.name])

    def exec_module(self, module):  # noqa: D102 - the module is already executed at its new place
        pass


def install() -> None:
    """Put the finder on ``sys.meta_path`` once."""
    if not any(isinstance(finder, MovedModuleFinder) for finder in sys.meta_path):
        sys.meta_path.append(MovedModuleFinder())
