"""The dynamics layer: Fossen hydrodynamics of the model's links and the free-floating plant (Pinocchio).

The loop that integrates a plant is :func:`uvms.simulate.simulate_plant` (one loop for every run).
"""

from .hydrodynamics import HydroParameters, LinkHydrodynamics, hydrodynamics_of
from .plant import Plant, PlantSystem, generalized_jacobian_added_mass

__all__ = ["HydroParameters", "LinkHydrodynamics", "Plant", "PlantSystem", "generalized_jacobian_added_mass",
           "hydrodynamics_of"]
