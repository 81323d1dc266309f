"""The control layer: controllers built on the solvers (GJM control of amundsen2018, phase sequences, vehicle
control, arm-vehicle coordination, station keeping).

A controller is run by the one simulation, :func:`uvms.sim.loop.simulate`: a kinematic controller on a ``Robot``,
the GJM controller on a ``Plant``, a vehicle controller (station keeping) on an ``ActuatedPlant``.
"""

from .coordination import CoordinatedControl, coordinated_arm_rates
from .gjm import GJMControlError, GJMController, VelocityRamps
from .sequence import Phase, PhasePlan, SequenceController
from .station import ActuatedKinematics, actuated_control, station_keeping
from .vehicle import VehiclePoseController, VehicleVelocityController, pose_velocity_reference

__all__ = ["ActuatedKinematics", "CoordinatedControl", "GJMControlError", "GJMController", "Phase", "PhasePlan",
           "SequenceController", "VehiclePoseController", "VehicleVelocityController", "VelocityRamps",
           "actuated_control", "coordinated_arm_rates", "pose_velocity_reference", "station_keeping"]
