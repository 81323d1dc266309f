"""Solvers: how to achieve tasks.

Inverses (pinv, weighted pinv, DLS with fixed or variable damping), CLIK with a
null-space term, task priority (classic and singularity-robust), kinematic
constraints (santos2006, with the screw/Davies formulation), pose IK and the
initial configuration of hoang2011. Every solver returns a result dataclass.
"""

from .clik import VariableDamping, clik_step, clik_velocity, damped_weighted_inverse
from .constraints import constrained_velocity
from .ik import solve_ik
from .initial import initial_configuration
from .inverses import SolverInputError, dls, pinv, variable_damping, weighted_pinv
from .pose_clik import PoseCLIK
from .priority import priority_velocity, task_priority
from .results import InitialConfigurationResult, IKResult, PriorityResult, StepResult, VelocityResult

__all__ = [
    "IKResult",
    "InitialConfigurationResult",
    "PoseCLIK",
    "PriorityResult",
    "SolverInputError",
    "StepResult",
    "VariableDamping",
    "VelocityResult",
    "clik_step",
    "clik_velocity",
    "constrained_velocity",
    "damped_weighted_inverse",
    "dls",
    "initial_configuration",
    "pinv",
    "priority_velocity",
    "solve_ik",
    "task_priority",
    "variable_damping",
    "weighted_pinv",
]
