"""LAPACK through ``scipy.linalg.lapack``, loaded on first use.

Importing ``scipy.linalg`` is about a third of ``import uvms``; the commands and notebooks that never solve
(``uvms info``, ``uvms view``, loading a model) need none of it. The solvers' inner loops call
``lapack().dgesdd(...)`` and pay a function call, not an import.
"""

from __future__ import annotations

from types import ModuleType

_module: ModuleType | None = None


def lapack() -> ModuleType:
    """The ``scipy.linalg.lapack`` module (imported at the first call)."""
    global _module
    if _module is None:
        from scipy.linalg import lapack as module

        _module = module
    return _module
