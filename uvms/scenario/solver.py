"""A scenario's ``[solver]``: its method looked up in :data:`uvms.solvers.SOLVERS` (the one place), its keys checked
against what the method takes, and the :class:`~uvms.solvers.base.SolverFactory` a controller builds it from."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import ScenarioError
from ..robot.robot import Robot
from ..solvers import SOLVERS, Solver, VariableDamping
from ..solvers.base import SolverFactory
from ..tasks import MidRangePotential
from .spec import SolverSpec
from .spec.keys import thaw

#: [solver] keys that set a constructor keyword of another name (the variable damping's two set ``damping``).
RENAMED_KEYWORDS = {"damping_epsilon": "damping", "damping_max": "damping"}
#: [solver] keys -> the solver constructor's keyword they set: every key of the section (a new option is its
#: SolverSpec key and the constructor's keyword of the same name), but solver.method and solver.joint_limit_weights,
#: which the initial configuration also reads, and which are not options of a solver.
SOLVER_KEYWORDS = {name: RENAMED_KEYWORDS.get(name, name) for name in SolverSpec.keys()
                   if name not in ("method", "joint_limit_weights")}


def scenario_solver(robot: Robot, solver: SolverSpec, dt: float, any_levels: str = "") -> SolverFactory:
    """The solver of the [solver] section on ``robot`` with the step dt [s]: :func:`solver_class`'s, built by a
    controller on its levels with :func:`solver_options`' keywords (what it can do: the factory's ``cls``).

    Raises:
        ScenarioError: as :func:`solver_class` and :func:`solver_weights`.
    """
    cls = solver_class(solver, any_levels)
    return SolverFactory(cls, robot, solver_options(robot, solver, cls, dt))


def solver_class(solver: SolverSpec, any_levels: str = "") -> type[Solver]:
    """The class of solver.method, every [solver] key the user set checked against what it takes: the one place
    a scenario's method is looked up in :data:`uvms.solvers.SOLVERS` (controllers get a SolverFactory of it).

    Args:
        solver: the [solver] section; any_levels: what needs a solver of any number of levels (e.g. a sequence
            scenario), refused a method of a fixed number (""; any method).

    Raises:
        ScenarioError: a method of a fixed number of levels for ``any_levels``; a key set (not at its default)
            that the method's constructor does not take; the message lists the keys it takes.
    """
    method = solver.method
    cls = SOLVERS[method]
    if any_levels and cls.level_count is not None:
        valid = [name for name, other in SOLVERS.items() if other.level_count is None]
        raise ScenarioError(f"{any_levels} needs solver.method in {', '.join(valid)} (a solver of any number of "
                            f"levels), got {method!r}")
    taken = cls.options()
    refused = [key for key in solver.changed(tuple(SOLVER_KEYWORDS))
               if SOLVER_KEYWORDS[key] not in taken]
    if refused:
        keys = ", ".join(f"solver.{key}" for key, keyword in SOLVER_KEYWORDS.items() if keyword in taken)
        hint = ""
        if cls.enforces_inequalities and refused[0] in ("alpha", "enforce_limits"):
            hint = ("; joint limits are an [[inequalities]] table of type 'joint_limits' (margin, band [rad]), "
                    "which it enforces")
        raise ScenarioError(f"solver.{refused[0]} is not used by solver.method = {method!r}, which takes {keys}: "
                            f"remove it or choose another method{hint}")
    return cls


def solver_damping(solver: SolverSpec) -> float | VariableDamping:
    """solver.damping, or the variable damping of amundsen2018 eq. 6 when solver.damping_epsilon > 0."""
    if solver.damping_epsilon > 0:
        return VariableDamping(solver.damping_epsilon, solver.damping_max)
    return solver.damping


def solver_options(robot: Robot, solver: SolverSpec, cls: type[Solver], dt: float) -> dict[str, Any]:
    """The constructor keywords of ``cls`` from the [solver] section (those it takes), with the step dt [s]."""
    offered = {key: getattr(solver, key) for key, keyword in SOLVER_KEYWORDS.items() if key == keyword}
    offered.update(gain=np.asarray(solver.gain, dtype=float), damping=solver_damping(solver), dt=dt)
    offered.pop("weights")  # checked against the model below
    taken = cls.options()
    options = {keyword: value for keyword, value in offered.items() if keyword in taken}
    if "weights" in taken:
        options["weights"] = solver_weights(robot, solver, free_floating=solver.free_floating)
    if "potential" in taken:
        options["potential"] = MidRangePotential(robot, weights=np.asarray(solver.joint_limit_weights,
                                                                             dtype=float))
    return options


def solver_weights(robot: Robot, solver: SolverSpec, free_floating: bool) -> np.ndarray | None:
    """``solver.weights`` as the diagonal W of the solved columns, checked against the model (None: not given).

    The solved columns are v's nv (the vehicle, then the arm), or the n_arm arm joints for free-floating
    (generalized-Jacobian) control, where the vehicle is not commanded.

    Raises:
        ScenarioError: the wrong count (the message says what the entries are), or an entry <= 0.
    """
    if not solver.weights:
        return None
    weights = np.asarray(solver.weights, dtype=float)
    if free_floating:
        size, covered = robot.n_arm, (f"free-floating (generalized-Jacobian) weights cover the arm joints only "
                                      f"({', '.join(robot.arm_joint_names)}); the vehicle is not commanded, it "
                                      f"moves by momentum conservation")
    else:
        vehicle = f"the vehicle ({', '.join(robot.base.pose_names)}) then " if robot.n_vehicle else ""
        size, covered = robot.nv, f"one per velocity coordinate: {vehicle}the arm ({', '.join(robot.arm_joint_names)})"
    if weights.shape != (size,):
        raise ScenarioError(f"solver.weights has {weights.size} numbers, {robot.name} needs {size}: {covered}")
    if np.any(weights <= 0):
        raise ScenarioError(f"solver.weights must all be > 0 (the diagonal of a positive definite W), "
                            f"got {thaw(solver.weights)}")
    return weights
