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

from .optional import INSTALL_HINT, require_crocoddyl, require_mim_solvers

__all__ = ["INSTALL_HINT", "MPCController", "MPCSettings", "PlantPrediction", "require_crocoddyl",
           "require_mim_solvers"]


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
