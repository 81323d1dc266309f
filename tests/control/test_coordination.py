"""Arm-vehicle coordination through the scenario's solver (uvms.control.coordination, uvms.control.station)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import uvms
from uvms.control.base import State
from uvms.control.coordination import CoordinatedControl, achieved_ratio, arm_rates_for_task, vehicle_rates_for_task
from uvms.control.reference import TaskReference
from uvms.control.station import ActuatedKinematics
from uvms.control.vehicle import VehiclePoseController
from uvms.solvers.base import SolverFactory
from uvms.tasks import FrameTask
from uvms.tasks.objectives import JointLimits
from uvms.trajectory import VelocityRamps

ARM = [3.0, 1.8, 1.8, 1.0, 0.0]


@pytest.fixture(scope="module")
def robot() -> uvms.Robot:
    return uvms.load("bluerov2_alpha5")


def test_achieved_ratio_is_what_the_allocation_gave_per_axis():
    asked = np.array([200.0, 10.0, -50.0, 1.0, 0.0, 3.0])
    achieved = np.array([130.0, 10.0, -25.0, 1.0, 0.0, -1.0])
    np.testing.assert_allclose(achieved_ratio(asked, achieved), [0.65, 1.0, 0.5, 1.0, 1.0, 0.0])


def vehicle_columns(rotation: np.ndarray, offset: np.ndarray) -> np.ndarray:
    """J_v (6, 6) of a frame at ``offset`` [m] in the body (rows world [linear; angular], columns body [v; w])."""
    skew = np.array([[0.0, -offset[2], offset[1]], [offset[2], 0.0, -offset[0]], [-offset[1], offset[0], 0.0]])
    return np.block([[rotation, -rotation @ skew], [np.zeros((3, 3)), rotation]])


def test_the_vehicle_carries_what_the_arm_cannot_translation_first():
    """No arm, a point 1.5 m off the vehicle's origin: the vehicle translates, it does not turn (a plain J_v^+
    would give 0.69 of the motion to a rotation); with orientation rows it gets them exactly; an arm that moves the
    point along x keeps x, the vehicle gives y and z."""
    rotation = pin.rpy.rpyToMatrix(0.1, -0.2, 0.7)
    jacobian = vehicle_columns(rotation, np.array([1.5, 0.0, -0.4]))
    wanted = np.array([0.3, -0.2, 0.1, 0.05, 0.0, -0.02])
    point = vehicle_rates_for_task(jacobian[:3], wanted[:3], 6)
    np.testing.assert_allclose(point[3:], 0.0, atol=1e-12)
    np.testing.assert_allclose(jacobian[:3] @ point, wanted[:3], atol=1e-12)
    np.testing.assert_allclose(jacobian @ vehicle_rates_for_task(jacobian, wanted, 6), wanted, atol=1e-12)
    with_arm = np.hstack([jacobian[:3], [[1.0], [0.0], [0.0]]])  # (3, 7): a prismatic joint along world x
    shared = vehicle_rates_for_task(with_arm, wanted[:3], 6)
    np.testing.assert_allclose(jacobian[:3] @ shared, [0.0, -0.2, 0.1], atol=1e-12)


def test_vehicle_bounds_lie_between_the_measured_velocity_and_what_the_thrusters_give(robot):
    control = CoordinatedControl.__new__(CoordinatedControl)
    control.ratio = np.array([0.25, 1.0, 0.0, 1.0, 1.0, 1.0])
    nu = np.array([-0.2, 0.0, 0.1, 0.0, 0.0, 0.0])
    nu_pose = np.array([0.5, 0.3, -0.1, 0.0, 0.0, 0.0])
    lower, upper = control.vehicle_bounds(nu, nu_pose)
    # surge: -0.2 + 0.25 * 0.7 = -0.025; heave: held at the measured 0.1
    np.testing.assert_allclose(lower, [-0.2, 0.0, 0.1, 0, 0, 0])
    np.testing.assert_allclose(upper, [-0.025, 0.3, 0.1, 0, 0, 0])


def kinematics(robot, target, solver, inequalities=()):
    pose = VehiclePoseController(None, 1.5, 0.5)
    hold = VelocityRamps.trapezoid(target, np.zeros(3), 1.0, 0.5)
    reference = TaskReference(FrameTask(robot, axes=("x", "y", "z")), hold)
    kinematics = ActuatedKinematics(robot, pose, reference, solver=solver, inequalities=inequalities, damping=0.01)
    kinematics.reset(State(robot.configuration(base=np.zeros(6), arm=ARM)))  # the station
    return kinematics


def test_the_re_solve_holds_the_measured_vehicle_velocity_and_keeps_the_joint_limits(robot):
    """Near the lower limit of alpha_axis_c (0 rad, margin 0.05) a measured vehicle velocity that the plain
    coordination formula takes up by driving that joint further down: through set_based with the joint-limit
    objective above the task, the joint is stopped (its rate >= 0), the other joints take up what they can."""
    q = robot.configuration(base=np.zeros(6), arm=[3.0, 1.8, 0.1, 1.0, 0.0])
    target = robot.fk(q).translation
    limits = JointLimits(robot, margin=0.05, band=0.2, joints=["alpha_axis_e", "alpha_axis_d", "alpha_axis_c"])
    index = robot.arm_joint_names.index("alpha_axis_c")
    measured = np.zeros(6)
    plain = kinematics(robot, target, SolverFactory(uvms.CLIKSolver, robot, {"damping": 0.01}))
    plain.arm_rates(0.0, q, measured)  # points the task at the target
    jacobian = plain.task.jacobian(plain._configuration)
    for direction in np.eye(6)[:3]:
        for sign in (1.0, -1.0):
            candidate = sign * 0.2 * direction
            if arm_rates_for_task(jacobian, np.zeros(3), candidate, 6, damping=0.01)[index] < -0.05:
                measured = candidate
    assert np.any(measured), "no vehicle velocity drives alpha_axis_c down"
    free = arm_rates_for_task(jacobian, np.zeros(3), measured, 6, damping=0.01)
    enforced = kinematics(robot, target, SolverFactory(uvms.SetBasedSolver, robot, {"damping": 0.01}),
                          [[limits]])
    arm = enforced.arm_rates(0.0, q, measured)
    assert free[index] < -0.05 and arm[index] >= -1e-9, (free[index], arm[index])
    # the vehicle level on top holds the measured velocity: the re-solve's vehicle part is it, up to the DLS
    # damping of its identity rows, lambda^2 / (1 + lambda^2) = 1e-4 of it with lambda = 0.01
    v, _ = enforced._solve(enforced._configuration, measured, reference=False, diagnostics=False)
    np.testing.assert_allclose(v[:6], measured, atol=1.01e-4 * np.linalg.norm(measured))


def test_the_reference_puts_the_pose_objective_below_the_task(robot):
    """A target 4 cm away: the solver's reference moves the end effector at K e with the vehicle at rest on its
    station (the pose objective in the task's null space, the arm doing the work)."""
    station = robot.configuration(base=np.zeros(6), arm=ARM)
    target = robot.fk(station).translation + np.array([0.0, 0.04, 0.0])
    k = kinematics(robot, target, SolverFactory(uvms.SetBasedSolver, robot, {"damping": 0.0}))
    v, info = k.reference(0.0, station)
    np.testing.assert_allclose(k.task.jacobian(k._configuration) @ v, [0.0, 0.04, 0.0], atol=1e-9)
    np.testing.assert_allclose(info["nu_pose"], 0.0, atol=1e-12)
    assert np.linalg.norm(v[:6]) < 1e-6 < np.linalg.norm(v[6:])


def test_the_coordination_re_solve_evaluates_the_objectives_and_the_task_once_per_step(tmp_path):
    """The intervention's chain (set-based, three objectives above the jaws): the re-solve at the measured q reads the
    rows the reference's solve evaluated (each objective and the task once a step, not twice) and gives the arm rates
    of a re-solve that evaluates them itself, bit for bit."""
    from pathlib import Path

    from uvms.dynamics.plant.command import State
    from uvms.scenario.build import build
    from uvms.scenario.schema import read_scenario

    scenario = Path(__file__).resolve().parents[2] / "scenarios" / "bluerov2_alpha5_intervention.toml"
    setup = build(read_scenario(scenario, ["outputs.figures=false"]))
    controller = setup.actuation.controller
    kinematic = controller.kinematic
    objectives = [item for level in kinematic.arm_solver.plan.levels for item in level.inequalities]
    assert len(objectives) == 3
    counts = dict.fromkeys([objective.name for objective in objectives] + ["task"], 0)
    for item, name in [*((objective, objective.name) for objective in objectives), (kinematic.task, "task")]:
        attribute = "terms" if name == "task" else "rows_into"  # what a hierarchy's evaluation calls
        original = getattr(item, attribute)

        def counted(state, *out, original=original, name=name):
            counts[name] += 1
            return original(state, *out)

        setattr(item, attribute, counted)
    rng = np.random.default_rng(3)
    nv = setup.robot.nv
    q, v = setup.q0, np.zeros(nv)
    controller.reset(State(q, v, np.zeros(8), np.zeros(0)), 0.0)
    for step in range(3):
        t = 0.5 + 0.01 * step
        q = pin.integrate(setup.robot.model, setup.q0, 0.02 * rng.normal(size=nv))
        v = 0.05 * rng.normal(size=nv)
        controller.command(State(q, v, np.zeros(8), np.zeros(0)), t)
        assert set(counts.values()) == {step + 1}, counts  # once a step for both solves
        kinematic.reference(t, q)
        shared = kinematic.arm_rates(t, q, v[:6])
        kinematic._rows.clear()
        alone = kinematic.arm_solver.velocity(kinematic._at(t, q)).v[6:]  # without the reference's rows
        assert np.array_equal(shared, alone)
        counts.update(dict.fromkeys(counts, step + 1))


def test_a_coordinated_step_is_the_reference_then_the_arm_rates_bit_for_bit():
    """``ActuatedKinematics.coordinated`` (the step's two solves at one configuration, v alone) gives the numbers of
    ``reference`` then ``arm_rates`` on a twin chain, whose reference keeps its SolverResult; and the set-based
    solver's ``stage_velocity`` with the shared rows gives ``velocity(...).v`` bit for bit."""
    from pathlib import Path

    from uvms.dynamics.plant.command import State
    from uvms.scenario.build import build
    from uvms.scenario.schema import read_scenario
    from uvms.solvers.result import SolverResult

    scenario = Path(__file__).resolve().parents[2] / "scenarios" / "bluerov2_alpha5_intervention.toml"
    spec = read_scenario(scenario, ["outputs.figures=false"])
    chains = [build(spec) for _ in range(2)]
    one, two = (setup.actuation.controller.kinematic for setup in chains)
    setup, rng = chains[0], np.random.default_rng(11)
    nv = setup.robot.nv
    for chain in chains:
        chain.actuation.controller.reset(State(setup.q0, np.zeros(nv), np.zeros(8), np.zeros(0)), 0.0)
    for step in range(4):
        t = 0.5 + 0.01 * step
        q = pin.integrate(setup.robot.model, setup.q0, 0.05 * rng.normal(size=nv))
        measured = 0.05 * rng.normal(size=6)
        reference, arm = one.coordinated(t, q, measured)
        twin_reference, info = two.reference(t, q)
        assert isinstance(info["solver"], SolverResult)
        assert np.array_equal(reference, twin_reference) and np.array_equal(reference, info["solver"].v)
        assert np.array_equal(arm, two.arm_rates(t, q, measured))
        assert np.linalg.norm(arm) > 1e-3  # the arm moves: the comparison is not one of zeros
        solver, state = two.arm_solver, two._configuration
        assert np.array_equal(solver.stage_velocity(state, shared=two._rows),
                              solver.velocity(state, shared=two._rows).v)
