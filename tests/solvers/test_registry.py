"""The one solver interface (uvms.solvers.base, uvms.solvers.SOLVERS): every registered method builds from the same
robot and task, returns one SolverResult with the documented fields, is the same object in a loop as fresh at
every step (bit for bit), and with free_floating=True gives a vehicle velocity that conserves the momentum."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import uvms
from uvms import Configuration
from uvms.errors import SolverInputError
from uvms.solvers import SOLVERS, Solver, SolverResult
from uvms.tasks.objectives import JointLimits

from conftest import shipped

DT = 0.05


def problem(robot: uvms.Robot, cls: type[Solver], free_floating: bool = False,
            step: bool = True) -> tuple[uvms.FrameTask, Solver]:
    """A frame task 5 cm away (x, y, z), the levels the class takes (a vehicle task where it uses one, joint
    limits above where it enforces inequalities), and the solver built on them (given dt where it takes one and
    ``step``)."""
    q = robot.neutral()
    task = uvms.FrameTask(robot, axes=("x", "y", "z"))
    target = robot.fk(q, task.frame)
    target.translation += np.array([0.05, -0.03, 0.02])
    task.set_target(target)
    levels: list = [task]
    if cls.enforces_inequalities:
        levels.insert(0, JointLimits(robot))
    if cls.vehicle_level is not None:
        heading = uvms.VehicleTask(robot, heading=0.1)
        levels.insert(cls.vehicle_level, heading)
    options = {"free_floating": free_floating}
    if "dt" in cls.options() and (step or cls.name == "hqp"):
        options["dt"] = DT
    return task, cls(robot, levels, **options)


def configurations(robot: uvms.Robot, rng: np.random.Generator, count: int) -> list[np.ndarray]:
    q0 = robot.neutral()
    return [pin.integrate(robot.model, q0, 0.3 * rng.standard_normal(robot.nv)) for _ in range(count)]


@pytest.mark.parametrize("method", sorted(SOLVERS))
def test_every_registered_solver_builds_and_returns_the_documented_result(method):
    robot = shipped("bluerov2_alpha5")
    cls = SOLVERS[method]
    assert cls.name == method and issubclass(cls, Solver)
    _, solver = problem(robot, cls)
    result = solver.velocity(Configuration(robot, robot.neutral()))
    assert isinstance(result, SolverResult)
    assert result.v.shape == (robot.nv,) and np.all(np.isfinite(result.v))
    assert isinstance(result.sigma_min, float) and result.sigma_min > 0
    assert isinstance(result.damping, float) and result.damping >= 0
    assert result.free_floating is False and isinstance(result.limits_active, tuple)
    assert isinstance(result.residual, float) and result.residual >= 0
    levels = 2 if cls.enforces_inequalities or cls.vehicle_level is not None else 1
    assert len(result.task_residuals) == levels and all(isinstance(r, float) for r in result.task_residuals)
    rows = 3 + (1 if cls.vehicle_level is not None else 0)  # x, y, z (+ the heading)
    assert result.command.shape == result.error.shape == (rows,)
    assert isinstance(result.objectives, tuple) and result.active == tuple(
        status.name for status in result.objectives if status.active)
    with pytest.raises(TypeError):
        result.extras["new"] = 1  # read-only
    with pytest.raises(SolverInputError, match="needs a uvms.Configuration"):
        solver.velocity(robot.neutral())


@pytest.mark.parametrize("method", sorted(SOLVERS))
def test_a_solver_in_a_loop_equals_a_fresh_solver_at_every_step_bit_for_bit(method, rng):
    robot = shipped("bluerov2_alpha5")
    task, kept = problem(robot, SOLVERS[method])
    configuration = Configuration(robot, robot.neutral())
    stepped = Configuration(robot, robot.neutral())
    for index, q in enumerate(configurations(robot, rng, 4)):
        target = robot.fk(q, task.frame)
        target.translation += 0.01 * index
        task.set_target(target)
        configuration.update(q)
        reused = kept.velocity(configuration)
        fresh = rebuilt(robot, kept, task).velocity(Configuration(robot, q))  # built for this step
        assert np.array_equal(reused.v, fresh.v)
        assert reused.sigma_min == fresh.sigma_min and reused.damping == fresh.damping
        assert reused.task_residuals == fresh.task_residuals and reused.scales == fresh.scales
        before = stepped.q.copy()
        result = kept.step(stepped, DT)
        assert np.array_equal(stepped.q, pin.integrate(robot.model, before, result.v * DT))


def rebuilt(robot: uvms.Robot, solver: Solver, task: uvms.FrameTask) -> Solver:
    """A new solver of the same class on the same task object (the other levels rebuilt alike)."""
    cls = type(solver)
    levels: list = [task]
    if cls.enforces_inequalities:
        levels.insert(0, JointLimits(robot))
    if cls.vehicle_level is not None:
        levels.insert(cls.vehicle_level, uvms.VehicleTask(robot, heading=0.1))
    options = {"free_floating": solver.free_floating}
    if "dt" in cls.options():
        options["dt"] = DT
    return cls(robot, levels, **options)


@pytest.mark.parametrize("method", sorted(SOLVERS))
def test_free_floating_conserves_the_momentum_with_every_solver(method, rng):
    """A v = 0 with the centroidal map A (6, nv) at the configuration: the vehicle follows the arm (the solvers
    unbounded where they can be: the kinematic constraint's heading would need arm speeds beyond the Alpha 5's)."""
    robot = shipped("bluerov2_alpha5")
    _, solver = problem(robot, SOLVERS[method], free_floating=True, step=False)
    for q in configurations(robot, rng, 3):
        configuration = Configuration(robot, q)
        result = solver.velocity(configuration)
        assert result.free_floating and np.all(np.isfinite(result.v))
        assert np.abs(result.v[robot.n_vehicle:]).max() > 1e-6  # the arm moves
        centroidal = pin.computeCentroidalMap(robot.model, robot.model.createData(), q)  # (6, nv)
        assert np.abs(centroidal @ result.v).max() <= 1e-10


def test_the_registry_is_what_the_scenario_schema_offers():
    from uvms.scenario.spec import SolverSpec

    assert tuple(SolverSpec.keys()["method"].allowed) == tuple(SOLVERS) == (  # the schema holds a live view of the keys
        "clik", "task_priority", "kinematic_constraint", "set_based", "hqp")
    assert [name for name, cls in SOLVERS.items() if cls.enforces_inequalities] == ["set_based", "hqp"]
    assert {name: cls.vehicle_level for name, cls in SOLVERS.items() if cls.vehicle_level is not None} == {
        "task_priority": 1, "kinematic_constraint": 0}


def test_step_moves_the_configuration_and_refuses_a_bad_dt():
    robot = shipped("bluerov2_alpha5")
    task, solver = problem(robot, SOLVERS["clik"])
    configuration = Configuration(robot, robot.neutral())
    error = np.linalg.norm(solver.velocity(configuration).error)
    for _ in range(40):
        solver.step(configuration, 0.1)
    assert np.linalg.norm(solver.velocity(configuration).error) < 0.02 * error
    with pytest.raises(SolverInputError, match="dt"):
        solver.step(configuration, 0.0)
