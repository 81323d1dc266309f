"""Whole-body model-predictive control of the vehicle and the arm on Crocoddyl (issue 49).

- :mod:`.settings`: :class:`MPCSettings` (horizon, node step, iterations, weights); no Crocoddyl needed.
- :mod:`.prediction`: the plant's equations of motion with thrusts and arm commands as inputs, and their analytical
  derivatives (:class:`PlantPrediction`; Pinocchio and numpy, no Crocoddyl).
- :mod:`.action`: the plant as a Crocoddyl differential action model, and the costs of a node.
- :mod:`.constraints`: the scenario's inequality objectives as the nodes' constraints (CSQP) or penalties.
- :mod:`.controller`: :class:`MPCController` (``reset``, ``command(q, v, t)`` -> thrusts and arm commands).

Crocoddyl and mim-solvers are optional (``pip install 'uvms[mpc]'``); they are imported when an MPC is built, never
by ``import uvms``.
"""

from __future__ import annotations

import importlib
from types import ModuleType

from ...errors import UVMSError

INSTALL_HINT = "the whole-body MPC needs Crocoddyl: pip install 'uvms[mpc]'"

__all__ = ["INSTALL_HINT", "MPCController", "MPCSettings", "PlantPrediction", "require_crocoddyl",
           "require_mim_solvers"]


def require_crocoddyl() -> ModuleType:
    """The ``crocoddyl`` module.

    Raises:
        UVMSError: Crocoddyl is not installed (the message names the extra).
    """
    try:
        return importlib.import_module("crocoddyl")
    except ImportError as exc:
        raise UVMSError(f"{INSTALL_HINT} ({exc})") from None


def require_mim_solvers() -> ModuleType:
    """The ``mim_solvers`` module (CSQP), imported after Pinocchio and Crocoddyl (whose libraries it links to).

    Raises:
        UVMSError: mim-solvers is not installed (the message names the extra).
    """
    require_crocoddyl()
    try:
        return importlib.import_module("mim_solvers")
    except ImportError as exc:
        raise UVMSError(f"the MPC's constrained solver needs mim-solvers: pip install 'uvms[mpc]' ({exc})") from None


def __getattr__(name: str):
    if name == "MPCController":
        from .controller import MPCController

        return MPCController
    if name == "MPCSettings":
        from .settings import MPCSettings

        return MPCSettings
    if name == "PlantPrediction":
        from .prediction import PlantPrediction

        return PlantPrediction
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
