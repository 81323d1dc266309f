"""The control layer: controllers built on the solvers (GJM control of amundsen2018, phase sequences)."""

from .gjm import GJMControlError, GJMController, GJMResult, VelocityRamps, simulate_gjm
from .sequence import Phase, PhasePlan, SequenceController

__all__ = ["GJMControlError", "GJMController", "GJMResult", "Phase", "PhasePlan", "SequenceController",
           "VelocityRamps", "simulate_gjm"]
