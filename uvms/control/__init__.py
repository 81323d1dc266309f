"""The control layer: controllers built on the solvers (GJM control of amundsen2018, phase sequences, vehicle
control, arm-vehicle coordination, station keeping).

A controller is run by the one loop of :mod:`uvms.sim.simulate` (``simulate``, ``simulate_gjm``) and, for a vehicle
with thrusters, :func:`uvms.sim.actuated.simulate_actuated`.
"""

from .coordination import CoordinatedControl, coordinated_arm_rates
from .gjm import GJMControlError, GJMController, VelocityRamps
from .sequence import Phase, PhasePlan, SequenceController
from .station_keeping import StationKeeping, station_keeping
from .vehicle import VehiclePoseController, VehicleVelocityController, pose_velocity_reference

__all__ = ["CoordinatedControl", "GJMControlError", "GJMController", "Phase", "PhasePlan", "SequenceController",
           "StationKeeping", "VehiclePoseController", "VehicleVelocityController", "VelocityRamps",
           "coordinated_arm_rates", "pose_velocity_reference", "station_keeping"]
