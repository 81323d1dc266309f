"""The dynamics layer: Fossen hydrodynamics of the model's links, the free-floating plant (Pinocchio), the
vehicle's thrusters and their allocation; the identification of the vehicle's hydrodynamics from a log
(:func:`identify`).

The one simulation, :func:`uvms.sim.loop.simulate`, integrates a ``Plant`` and, with thrusters, an
``ActuatedPlant`` (each builds its system of the loop: ``PlantSystem``, ``ActuatedPlantSystem``).
"""

from .actuated import ActuatedCommand, ActuatedPlant, ActuatedPlantSystem, vehicle_inverse_dynamics
from .allocation import AllocationResult, ThrustAllocator
from .hydrodynamics import HydroParameters, LinkHydrodynamics, hydrodynamics_of
from .identification import IdentificationResult, identify
from .identification_data import IdentificationLog
from .added_mass import generalized_jacobian_added_mass
from .plant import Plant
from .plant_system import PlantSystem
from .thrusters import Thruster, Thrusters, allocation_matrix, thrusters_of

__all__ = ["ActuatedCommand", "ActuatedPlant", "ActuatedPlantSystem", "AllocationResult", "HydroParameters",
           "IdentificationLog", "IdentificationResult", "LinkHydrodynamics", "Plant", "PlantSystem", "ThrustAllocator",
           "Thruster", "Thrusters", "allocation_matrix", "generalized_jacobian_added_mass", "hydrodynamics_of",
           "identify", "thrusters_of", "vehicle_inverse_dynamics"]
