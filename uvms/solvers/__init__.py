"""Solvers: how to achieve tasks.

One inverse module (:mod:`.inverses`: pinv, weighted pinv, DLS with fixed or
variable damping, the SVD form with its diagnostics, the normal-equation form)
that every solver inverts with; one validator module (:mod:`.checks`); joint
limits read from :class:`uvms.robot.limits.Limit`. On top: CLIK with a null-space
term and joint clamping (and :class:`PoseCLIK`, its preallocated specialization
to one pose task), task priority (classic and singularity-robust), kinematic
constraints (santos2006, with the screw/Davies formulation), pose IK and the
initial configuration of hoang2011; the set-based (iCAT) task priority with inequality objectives and
the QP hierarchy on the same levels, both keeping speed limits by scaling the lowest levels first
(:mod:`.saturation`). Every solver returns a result dataclass.
"""

from ..errors import SolverInputError
from ..robot.limits import Limit
from .clik import CLIKSolver, clik_step, clik_velocity
from .constraints import constrained_velocity
from .hqp import hqp_step, hqp_velocity
from .ik import solve_ik
from .initial import initial_configuration
from ..numerics.inverses import (
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
from .results import (HQPResult, InitialConfigurationResult, IKResult, ObjectiveStatus, PriorityResult,
                      SetBasedResult, StepResult, VelocityResult)
from .set_based import SetBasedSolver, set_based_step, set_based_velocity

__all__ = [
    "HQPResult",
    "IKResult",
    "InitialConfigurationResult",
    "Limit",
    "ObjectiveStatus",
    "PoseCLIK",
    "PriorityResult",
    "SetBasedResult",
    "SolverInputError",
    "StepResult",
    "VariableDamping",
    "VelocityResult",
    "CLIKSolver",
    "clik_step",
    "clik_velocity",
    "constrained_velocity",
    "damped_weighted_inverse",
    "dls",
    "dls_solve",
    "hqp_step",
    "hqp_velocity",
    "initial_configuration",
    "pinv",
    "priority_velocity",
    "SetBasedSolver",
    "set_based_step",
    "set_based_velocity",
    "solve_ik",
    "task_priority",
    "variable_damping",
    "weighted_pinv",
]
