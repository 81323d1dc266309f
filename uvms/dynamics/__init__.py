"""The dynamics layer: Fossen hydrodynamics of the model's links, the free-floating plant (Pinocchio), the
vehicle's thrusters and their allocation.

The loop that integrates a plant is :func:`uvms.sim.simulate.simulate_plant` (one loop for every run); with
thrusters, :func:`uvms.sim.actuated.simulate_actuated` (the same loop).
"""

from .actuated import ActuatedCommand, ActuatedPlantSystem, ThrusterDynamics, vehicle_inverse_dynamics
from .allocation import AllocationResult, ThrustAllocator
from .hydrodynamics import HydroParameters, LinkHydrodynamics, hydrodynamics_of
from .added_mass import generalized_jacobian_added_mass
from .plant import Plant, PlantSystem
from .thrusters import Thruster, Thrusters, allocation_matrix, thrusters_of

__all__ = ["ActuatedCommand", "ActuatedPlantSystem", "AllocationResult", "HydroParameters", "LinkHydrodynamics",
           "Plant", "PlantSystem", "ThrustAllocator", "Thruster", "ThrusterDynamics", "Thrusters",
           "allocation_matrix", "generalized_jacobian_added_mass", "hydrodynamics_of", "thrusters_of",
           "vehicle_inverse_dynamics"]
