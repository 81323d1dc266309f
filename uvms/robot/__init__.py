"""The robot layer: a Pinocchio model seen as a vehicle plus arms, and its configurations.

:class:`Robot` (vehicle base facts, arms, Fossen accessors, joint limits as one :class:`Limit`),
the state of one configuration (:mod:`.configuration`), the one generalized-Jacobian formula
(:mod:`.kinematics`) and the frame conventions (:mod:`.conventions`).
"""

from .configuration import Configuration
from .limits import Limit
from .robot import Robot

__all__ = ["Configuration", "Limit", "Robot"]
