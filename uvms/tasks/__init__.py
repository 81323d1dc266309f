"""Tasks: what to achieve. Each gives an error e (desired - current), a Jacobian J and a feedforward velocity.

CLIK drives a task with  J v = xdot_d + K e.
"""

from .frame import FrameTask
from .joint_limits import JointLimitPotential
from .joints import JointTask
from .posture import PostureTask
from .relative import DistanceTask
from .task import Task
from .vehicle import VehicleTask

__all__ = ["DistanceTask", "FrameTask", "JointLimitPotential", "JointTask", "PostureTask", "Task", "VehicleTask"]
