"""Crocoddyl and mim-solvers, the MPC's optional dependencies (the ``mpc`` extra): imported when an MPC is built."""

from __future__ import annotations

import importlib
from types import ModuleType

from ...errors import UVMSError

INSTALL_HINT = "the whole-body MPC needs Crocoddyl: pip install 'uvms[mpc]'"


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
