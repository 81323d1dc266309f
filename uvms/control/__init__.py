"""The control layer: controllers built on the solvers (GJM control of amundsen2018, phase sequences).

A controller is run by the one loop of :mod:`uvms.simulate` (``simulate``, ``simulate_gjm``).
"""

from .gjm import GJMControlError, GJMController, VelocityRamps
from .sequence import Phase, PhasePlan, SequenceController

__all__ = ["GJMControlError", "GJMController", "Phase", "PhasePlan", "SequenceController", "VelocityRamps"]
