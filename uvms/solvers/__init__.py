"""Solvers: how to achieve tasks.

Every velocity method is a :class:`Solver` (:mod:`.base`): built once from the robot, the levels (equality
tasks and inequality objectives) and its options, it answers ``velocity(configuration)`` (and
``step(configuration, dt)``) with one :class:`SolverResult`. Free floating (the generalized Jacobian) is an
option of every one. :data:`SOLVERS` maps each scenario ``solver.method`` to its class: adding a method is
one module and one line here.

* :class:`CLIKSolver` — CLIK (hoang2011, amundsen2018): weights, fixed or variable damping, null-space
  potential, joint clamping;
* :class:`PrioritySolver` — classic and singularity-robust task priority;
* :class:`ConstraintSolver` — the kinematic constraints of santos2006;
* :class:`SetBasedSolver` — set-based (iCAT) priority with inequality objectives;
* :class:`HQPSolver` — the QP hierarchy on the same levels.

:func:`solve_ik` (pose IK) and :func:`initial_configuration` (hoang2011 sec. 2.3) solve for a configuration.
The inverses they all use are in :mod:`uvms.numerics.inverses`.
"""

from ..numerics.inverses import VariableDamping
from .base import Solver
from .clik import CLIKSolver
from .constraints import ConstraintSolver
from .hqp import HQPSolver
from .ik import solve_ik
from .initial import initial_configuration
from .priority import PrioritySolver
from .result import SolverResult
from .set_based import SetBasedSolver

#: solver.method -> the class (its ``name``), in the order the scenario reference lists them.
SOLVERS: dict[str, type[Solver]] = {cls.name: cls for cls in (
    CLIKSolver, PrioritySolver, ConstraintSolver, SetBasedSolver, HQPSolver)}

__all__ = ["CLIKSolver", "ConstraintSolver", "HQPSolver", "PrioritySolver", "SOLVERS", "SetBasedSolver", "Solver",
           "SolverResult", "VariableDamping", "initial_configuration", "solve_ik"]
