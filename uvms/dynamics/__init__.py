"""The dynamics layer, a folder per concern: ``hydro`` (Fossen hydrodynamics of the model's links), ``plant`` (the
free-floating plant, Pinocchio), ``thrusters`` (the vehicle's thrusters and fins and their allocation), ``plugins``
(the readers of simulator plugin blocks), ``identification`` (the vehicle's hydrodynamics from a log,
:func:`identify`).

The one simulation, :func:`uvms.sim.loop.simulate`, integrates a ``Plant`` and, with thrusters, an
``ActuatedPlant`` (each builds its system of the loop: ``PlantSystem``, ``ActuatedPlantSystem``).
"""

from .hydro.hydrodynamics import HydroParameters, LinkHydrodynamics, hydrodynamics_of
from .identification.data import IdentificationLog
from .identification.identify import IdentificationResult, identify
from .plant.actuated import ActuatedPlant, ActuatedPlantSystem, vehicle_inverse_dynamics
from .plant.added_mass import generalized_jacobian_added_mass
from .plant.command import Command, State
from .plant.plant import Plant
from .plant.system import PlantSystem
from .thrusters.allocation import AllocationResult, ThrustAllocator
from .thrusters.thrusters import Thruster, Thrusters, allocation_matrix, thrusters_of

__all__ = ["ActuatedPlant", "ActuatedPlantSystem", "AllocationResult", "Command", "HydroParameters",
           "IdentificationLog", "IdentificationResult", "LinkHydrodynamics", "Plant", "PlantSystem", "State",
           "ThrustAllocator", "Thruster", "Thrusters", "allocation_matrix", "generalized_jacobian_added_mass",
           "hydrodynamics_of", "identify", "thrusters_of", "vehicle_inverse_dynamics"]
