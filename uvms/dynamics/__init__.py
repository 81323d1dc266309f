"""The dynamics layer: Fossen hydrodynamics of the model's links and the free-floating plant (Pinocchio)."""

from .hydrodynamics import HydroParameters, LinkHydrodynamics, hydrodynamics_of
from .plant import Plant, PlantSystem, generalized_jacobian_added_mass

__all__ = ["HydroParameters", "LinkHydrodynamics", "Plant", "PlantResult", "PlantSystem",
           "generalized_jacobian_added_mass", "hydrodynamics_of", "simulate_plant"]


def __getattr__(name: str):
    """``simulate_plant`` and ``PlantResult`` live in :mod:`uvms.simulate` (the one loop, above the dynamics); this
    old path keeps working for one release."""
    if name in ("simulate_plant", "PlantResult"):
        from ..simulate import PlantResult, simulate_plant  # lazily: the loop sits above this layer

        return {"PlantResult": PlantResult, "simulate_plant": simulate_plant}[name]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
