"""uvms: model-driven kinematics and dynamics of underwater vehicle-manipulator systems, backed by Pinocchio.

Vehicles and arms are data (xacro/URDF with a floating or planar root joint);
Pinocchio computes every pose, Jacobian and momentum map.

>>> import uvms
>>> robot = uvms.load("hoang2011")                     # a shipped model, or any .urdf/.xacro path
>>> q = robot.configuration(base=[0.0, 0.0, 0.0], arm=[1.0, 0.5, 0.2])
>>> robot.fk(q).translation.round(3)
array([ 1.433, -0.806,  0.   ])

Here are the names a user needs first; everything else lives in its layer, one folder each, data flowing down
this list: ``uvms.errors`` (every exception), ``uvms.model`` (files in), ``uvms.robot`` (Robot, Configuration,
Limit), ``uvms.tasks`` (tasks and inequality objectives), ``uvms.solvers`` (the solvers and their
``SOLVERS`` registry), ``uvms.trajectory``, ``uvms.dynamics`` (hydrodynamics, plant, thrusters),
``uvms.workspace``, ``uvms.control``, ``uvms.sim`` (the one simulation), ``uvms.viz``, ``uvms.scenario``,
``uvms.cli``.

A name and a layer are imported when first used (``uvms.load``, ``uvms.dynamics.ThrustAllocator``): ``import uvms``
alone loads the errors only, so that a command (``uvms info``, ``uvms view``) pays for the layers it uses.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from .errors import UVMSError

if TYPE_CHECKING:  # the names below, for type checkers and editors (imported at first use at run time)
    from . import control, dynamics, errors, model, robot, scenario, sim, solvers, tasks, trajectory, workspace  # noqa: F401
    from .dynamics import Plant
    from .model import load
    from .robot import Configuration, Limit, Robot
    from .scenario import run_scenario
    from .sim import simulate
    from .solvers import CLIKSolver, ConstraintSolver, HQPSolver, PrioritySolver, SetBasedSolver, solve_ik
    from .tasks import DistanceTask, FrameTask, JointTask, PostureTask, VehicleTask
    from .workspace import monte_carlo

__version__ = "0.1.0"

__all__ = [
    "UVMSError",
    # a model and its configurations
    "load", "Robot", "Configuration", "Limit",
    # what to achieve
    "FrameTask", "JointTask", "PostureTask", "VehicleTask", "DistanceTask",
    # how: the solvers (uvms.solvers.SOLVERS names them for scenarios), and pose IK
    "CLIKSolver", "PrioritySolver", "ConstraintSolver", "SetBasedSolver", "HQPSolver", "solve_ik",
    # running it: one simulation (kinematic, free-floating Plant, actuated), a scenario file, the workspace
    "Plant", "simulate", "run_scenario", "monte_carlo",
]

#: The layers, attributes of ``uvms`` (``uvms.dynamics.ThrustAllocator`` works after ``import uvms``).
LAYERS = ("control", "dynamics", "io", "model", "numerics", "robot", "scenario", "sim", "solvers", "tasks",
          "trajectory", "viz", "workspace", "cli")
#: Each top-level name -> the layer that defines it.
_HOMES = {
    "load": "model", "Robot": "robot", "Configuration": "robot", "Limit": "robot",
    "FrameTask": "tasks", "JointTask": "tasks", "PostureTask": "tasks", "VehicleTask": "tasks", "DistanceTask": "tasks",
    "CLIKSolver": "solvers", "PrioritySolver": "solvers", "ConstraintSolver": "solvers", "SetBasedSolver": "solvers",
    "HQPSolver": "solvers", "solve_ik": "solvers", "Plant": "dynamics", "simulate": "sim",
    "run_scenario": "scenario", "monte_carlo": "workspace",
}


def __getattr__(name: str) -> Any:
    """A layer or a top-level name, imported at its first use (PEP 562) and kept as an attribute."""
    if name in LAYERS:
        value: Any = importlib.import_module(f".{name}", __name__)
    elif name in _HOMES:
        value = getattr(importlib.import_module(f".{_HOMES[name]}", __name__), name)
    else:
        raise AttributeError(f"module 'uvms' has no attribute {name!r}; the top-level names are "
                             f"{', '.join(__all__)}, and the layers {', '.join(LAYERS)}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__, *LAYERS})
