"""The dynamics layer: Fossen hydrodynamics of the model's links and the free-floating plant (Pinocchio)."""

from .hydrodynamics import HydroParameters, LinkHydrodynamics, hydrodynamics_of
from .plant import Plant, PlantResult, generalized_jacobian_added_mass, simulate_plant

__all__ = ["HydroParameters", "LinkHydrodynamics", "Plant", "PlantResult", "generalized_jacobian_added_mass",
           "hydrodynamics_of", "simulate_plant"]
