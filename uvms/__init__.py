"""uvms: model-driven kinematics of underwater vehicle-manipulator systems, backed by Pinocchio.

Vehicles and arms are data (xacro/URDF with a floating or planar root joint);
Pinocchio computes every pose, Jacobian and momentum map.

>>> import uvms
>>> robot = uvms.load("hoang2011")                     # a shipped model, or any .urdf/.xacro path
>>> q = robot.configuration(base=[0.0, 0.0, 0.0], arm=[1.0, 0.5, 0.2])
>>> robot.fk(q).translation.round(3)
array([ 1.433, -0.806,  0.   ])

The public names, by layer (data flows down this list; no module imports one above it):
"""

# errors: one root, every exception
from .errors import (
    BaseMismatchError,
    ConfigurationError,
    FrameNotFound,
    JointNotFound,
    ModelCheckError,
    ModelFileNotFound,
    ModelParseError,
    NoVehicleError,
    NotARobot,
    NumericalError,
    SolverInputError,
    UVMSError,
    WorkspaceInputError,
    XacroError,
)

# model: xacro/URDF -> checked Pinocchio model -> Robot
from .model import BaseGuessWarning, MissingMeshWarning, example_robot_urdf, load, mount_arm, shipped_models

# robot and kinematics
from .robot.limits import Limit
from .robot.robot import Robot
from .robot.configuration import Configuration

# tasks and solvers: what to achieve, how
from .tasks import DistanceTask, FrameTask, JointLimitPotential, JointTask, PostureTask, VehicleTask
from .solvers import (
    CLIKSolver,
    ConstraintSolver,
    HQPSolver,
    PrioritySolver,
    SetBasedSolver,
    SolverResult,
    VariableDamping,
    initial_configuration,
    solve_ik,
)

# trajectories
from .trajectory import ViaPointTrajectory, ctraj, jtraj

# dynamics: hydrodynamics and the free-floating plant
from .dynamics import (HydroParameters, LinkHydrodynamics, Plant, ThrustAllocator, allocation_matrix,
                       generalized_jacobian_added_mass, hydrodynamics_of, thrusters_of)

# control
from .control import GJMControlError, GJMController, StationKeeping, VelocityRamps, station_keeping

# the one simulation, for the kinematic, passive free-floating and actuated plants, and its result
from .sim import SimulationResult, simulate

# workspace
from .workspace import BatchKinematics, WorkspaceResult, monte_carlo

__version__ = "0.1.0"

__all__ = [
    # errors
    "BaseMismatchError", "ConfigurationError", "FrameNotFound", "JointNotFound", "ModelCheckError",
    "ModelFileNotFound", "ModelParseError", "NoVehicleError", "NotARobot", "NumericalError", "UVMSError", "WorkspaceInputError", "XacroError",
    # model
    "BaseGuessWarning", "MissingMeshWarning", "example_robot_urdf", "load", "mount_arm", "shipped_models",
    # robot and kinematics
    "Configuration", "Limit", "Robot",
    # tasks and solvers
    "DistanceTask", "FrameTask", "JointLimitPotential", "JointTask", "PostureTask", "VehicleTask",
    "CLIKSolver", "ConstraintSolver", "HQPSolver", "PrioritySolver", "SetBasedSolver", "SolverInputError",
    "SolverResult", "VariableDamping", "initial_configuration", "solve_ik",
    # trajectories
    "ViaPointTrajectory", "ctraj", "jtraj",
    # dynamics
    "HydroParameters", "LinkHydrodynamics", "Plant", "ThrustAllocator", "allocation_matrix",
    "generalized_jacobian_added_mass", "hydrodynamics_of", "thrusters_of",
    # control
    "GJMControlError", "GJMController", "StationKeeping", "VelocityRamps", "station_keeping",
    # simulation
    "SimulationResult", "simulate",
    # workspace
    "BatchKinematics", "WorkspaceResult", "monte_carlo",
]
