"""Tasks: what to achieve. Each gives an error e (desired - current), a Jacobian J and a feedforward velocity.

CLIK drives a task with  J v = xdot_d + K e.
"""

from .frame import FrameTask
from .joint_limits import JointLimitPotential
from .posture import PostureTask
from .task import Task
from .vehicle import VehicleTask

__all__ = ["FrameTask", "JointLimitPotential", "PostureTask", "Task", "VehicleTask"]
