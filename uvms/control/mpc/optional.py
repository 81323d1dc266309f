"""Crocoddyl, the MPC's optional dependency (the ``mpc`` extra): imported when an MPC is built, never before."""

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
