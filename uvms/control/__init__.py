"""The control layer: one :class:`Controller` interface (``reset``, ``command(state, t) -> Command``) and its
implementations on the solvers: kinematic tracking, phase sequences, GJM control of amundsen2018 (a passive
vehicle), the actuated chain (vehicle loops, allocation, arm-vehicle coordination, station keeping) and open loop.

:func:`uvms.sim.loop.simulate` runs any of them on any plant: a ``Robot`` (kinematic), a ``Plant`` (passive) or an
``ActuatedPlant`` (thrusters).
"""

from .base import Command, Controller, OpenLoop, State
from .coordination import CoordinatedControl, coordinated_arm_rates
from .gjm import GJMControlError, GJMController, VelocityRamps
from .reference import TaskReference
from .sequence import Phase, PhasePlan, SequenceController
from .settings import ActuatedSettings
from .station import ActuatedKinematics, actuated_control, station_keeping
from .tracking import TrackingController
from .vehicle import VehiclePoseController, VehicleVelocityController, pose_velocity_reference

__all__ = ["ActuatedKinematics", "ActuatedSettings", "Command", "Controller", "CoordinatedControl",
           "GJMControlError", "GJMController", "OpenLoop", "Phase", "PhasePlan", "SequenceController", "State",
           "TaskReference", "TrackingController", "VehiclePoseController", "VehicleVelocityController", "VelocityRamps",
           "actuated_control", "coordinated_arm_rates", "pose_velocity_reference", "station_keeping"]
