"""Tasks: what to achieve. Each gives an error e (desired - current), a Jacobian J and a feedforward velocity.

CLIK drives a task with  J v = xdot_d + K e. Inequality objectives (:mod:`.objectives`: joint limits,
vehicle attitude, plane clearance, manipulability, a frame in a box, speed limits) have a valid set
instead of a target; the set-based and QP hierarchies of :mod:`uvms.solvers` place them above the tasks.
"""

from .frame import FrameTask
from .joints import JointTask
from .objectives import (
    FrameBox,
    Inequality,
    JointLimits,
    JointVelocityLimits,
    Manipulability,
    PlaneClearance,
    VehicleAttitude,
    VehicleVelocityLimits,
    VelocityLimit,
    inequalities_from_table,
)
from .posture import PostureTask
from .potential import MidRangePotential
from .relative import DistanceTask
from .task import Task
from .vehicle import VehicleTask

__all__ = [
    "DistanceTask", "FrameBox", "FrameTask", "Inequality", "JointLimits", "JointTask", "MidRangePotential",
    "JointVelocityLimits", "Manipulability", "PlaneClearance", "PostureTask", "Task", "VehicleAttitude",
    "VehicleTask", "VehicleVelocityLimits", "VelocityLimit", "inequalities_from_table",
]
