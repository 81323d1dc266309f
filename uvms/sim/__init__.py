"""The one simulation (:func:`uvms.sim.loop.simulate` over one System protocol) and its immutable result."""

from .loop import simulate
from .result import SimulationResult
from .series import ActuationSeries, PlantSeries, TrackingSeries
from .system import Simulable, System

__all__ = ["ActuationSeries", "PlantSeries", "SimulationResult", "Simulable", "System", "TrackingSeries",
           "simulate"]
