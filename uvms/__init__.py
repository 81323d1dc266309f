"""uvms: model-driven kinematics of underwater vehicle-manipulator systems, backed by Pinocchio.

Vehicles and arms are data (xacro/URDF with a floating or planar root joint);
Pinocchio computes every pose, Jacobian and momentum map.

>>> import uvms
>>> robot = uvms.load("hoang2011")                     # a shipped model, or any .urdf/.xacro path
>>> q = robot.configuration(base=[0.0, 0.0, 0.0], arm=[1.0, 0.5, 0.2])
>>> robot.fk(q).translation.round(3)
array([ 1.433, -0.806,  0.   ])
"""

from .compose import mount_arm
from .errors import (
    BaseMismatchError,
    ConfigurationError,
    FrameNotFound,
    JointNotFound,
    ModelCheckError,
    ModelFileNotFound,
    ModelParseError,
    UVMSError,
    WorkspaceInputError,
    XacroError,
)
from .gjm_control import GJMControlError, GJMController, GJMResult, VelocityRamps, simulate_gjm
from .hydrodynamics import HydroParameters, LinkHydrodynamics, hydrodynamics_of
from .model import MissingMeshWarning, load
from .plant import Plant, PlantResult, generalized_jacobian_added_mass, simulate_plant
from .resources import example_robot_urdf, shipped_models
from .robot import Robot
from .solvers import (
    SolverInputError,
    VariableDamping,
    clik_step,
    clik_velocity,
    constrained_velocity,
    initial_configuration,
    priority_velocity,
    solve_ik,
)
from .state import KinematicState
from .tasks import DistanceTask, FrameTask, JointLimitPotential, JointTask, PostureTask, VehicleTask
from .trajectory import ViaPointTrajectory, ctraj, jtraj
from .workspace import BatchKinematics, WorkspaceResult, monte_carlo

__version__ = "0.1.0"

__all__ = [
    "GJMControlError",
    "GJMController",
    "GJMResult",
    "VelocityRamps",
    "simulate_gjm",
    "BatchKinematics",
    "WorkspaceInputError",
    "WorkspaceResult",
    "monte_carlo",
    "DistanceTask",
    "HydroParameters",
    "JointTask",
    "LinkHydrodynamics",
    "Plant",
    "PlantResult",
    "ViaPointTrajectory",
    "ctraj",
    "generalized_jacobian_added_mass",
    "hydrodynamics_of",
    "jtraj",
    "simulate_plant",
    "FrameTask",
    "JointLimitPotential",
    "KinematicState",
    "PostureTask",
    "SolverInputError",
    "VariableDamping",
    "VehicleTask",
    "clik_step",
    "clik_velocity",
    "constrained_velocity",
    "initial_configuration",
    "priority_velocity",
    "solve_ik",
    "BaseMismatchError",
    "ConfigurationError",
    "FrameNotFound",
    "JointNotFound",
    "MissingMeshWarning",
    "ModelCheckError",
    "ModelFileNotFound",
    "ModelParseError",
    "Robot",
    "UVMSError",
    "XacroError",
    "example_robot_urdf",
    "load",
    "mount_arm",
    "shipped_models",
]
