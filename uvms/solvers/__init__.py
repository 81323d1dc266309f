"""Solvers: how to achieve tasks.

One inverse module (:mod:`.inverses`: pinv, weighted pinv, DLS with fixed or
variable damping, the SVD form with its diagnostics, the normal-equation form)
that every solver inverts with; one validator module (:mod:`.checks`); joint
limits read from :class:`uvms.limits.Limit`. On top: CLIK with a null-space
term and joint clamping (and :class:`PoseCLIK`, its preallocated specialization
to one pose task), task priority (classic and singularity-robust), kinematic
constraints (santos2006, with the screw/Davies formulation), pose IK and the
initial configuration of hoang2011. Every solver returns a result dataclass.
"""

from ..errors import SolverInputError
from ..limits import Limit
from .clik import clik_step, clik_velocity
from .constraints import constrained_velocity
from .ik import solve_ik
from .initial import initial_configuration
from .inverses import (
    VariableDamping,
    damped_weighted_inverse,
    dls,
    dls_solve,
    pinv,
    variable_damping,
    weighted_pinv,
)
from .pose_clik import PoseCLIK
from .priority import priority_velocity, task_priority
from .results import InitialConfigurationResult, IKResult, PriorityResult, StepResult, VelocityResult

__all__ = [
    "IKResult",
    "InitialConfigurationResult",
    "Limit",
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
    "dls_solve",
    "initial_configuration",
    "pinv",
    "priority_velocity",
    "solve_ik",
    "task_priority",
    "variable_damping",
    "weighted_pinv",
]
