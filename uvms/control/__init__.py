"""The control layer: controllers built on the solvers (GJM control of amundsen2018, phase sequences)."""

from .gjm import GJMControlError, GJMController, VelocityRamps
from .sequence import Phase, PhasePlan, SequenceController

__all__ = ["GJMControlError", "GJMController", "GJMResult", "Phase", "PhasePlan", "SequenceController",
           "VelocityRamps", "simulate_gjm"]


def __getattr__(name: str):
    """``simulate_gjm`` and ``GJMResult`` live in :mod:`uvms.simulate` (the one loop, above the controllers); this
    old path keeps working for one release."""
    if name in ("simulate_gjm", "GJMResult"):
        from ..simulate import GJMResult, simulate_gjm  # lazily: the loop sits above this layer

        return {"GJMResult": GJMResult, "simulate_gjm": simulate_gjm}[name]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
