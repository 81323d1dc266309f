"""The one controller interface (uvms.control.base): every controller a Controller, driven one way by every plant;
its solver in one form (a SolverFactory), its capabilities read from the class."""

from __future__ import annotations

import re

import numpy as np
import pytest

import uvms
from uvms.control import Controller, OpenLoop, station_keeping
from uvms.control.base import State
from uvms.control.coordination import arm_rates_for_task
from uvms.control.reference import TaskReference
from uvms.control.station import ActuatedKinematics
from uvms.control.vehicle import VehiclePoseController
from uvms.dynamics.plant.actuated import ActuatedPlant
from uvms.errors import UVMSError
from uvms.scenario import read_scenario
from uvms.scenario.build import build
from uvms.sim import simulate
from uvms.solvers import CLIKSolver, PrioritySolver
from uvms.solvers.base import SolverFactory
from uvms.solvers.stack import stacked_terms
from uvms.tasks import FrameTask
from uvms.trajectory import VelocityRamps

from conftest import ROOT, shipped

ARM = [3.0, 1.8, 1.8, 1.0, 0.005]


@pytest.fixture(scope="module")
def blue():
    return shipped("bluerov2_alpha5")


def test_every_controller_is_a_controller(blue):
    tracking = build(read_scenario(ROOT / "scenarios" / "hoang2011_w1.toml")).controller
    sequence = build(read_scenario(ROOT / "scenarios" / "xiang2019_grip.toml")).controller
    gjm = build(read_scenario(ROOT / "scenarios" / "hoang2011_gjm.toml")).controller
    chain = station_keeping(ActuatedPlant(uvms.Plant(blue), uvms.dynamics.thrusters_of(blue)), blue.neutral(), 0.01)
    for controller in (tracking, sequence, gjm, chain, OpenLoop(arm=np.zeros(3))):
        assert isinstance(controller, Controller), type(controller).__name__


def chain_kinematics(robot, solver):
    """An ActuatedKinematics holding the end-effector point 4 cm off where it is."""
    q = robot.configuration(base=np.zeros(6), arm=ARM)
    target = robot.fk(q).translation + np.array([0.0, 0.04, 0.01])
    hold = VelocityRamps.trapezoid(target, np.zeros(3), 1.0, 0.5)
    task = FrameTask(robot, axes=("x", "y", "z"))
    kinematics = ActuatedKinematics(robot, VehiclePoseController(None, 1.5, 0.5), TaskReference(task, hold),
                                    solver=solver, gain=1.0, damping=0.01)
    kinematics.reset(State(q))  # the station
    return kinematics, q


def test_clik_on_the_actuated_chain_is_the_solver_with_the_vehicle_as_fixed_columns(blue):
    """CLIK (no priorities) gets the vehicle's velocity as fixed columns: the arm rates of the one solver object
    equal the former hand-written law J_a^# (K e + xdot_d - J_v nu) (DLS 0.01) to rounding, the vehicle part is nu
    exactly, and the result is the solver's (its diagnostics recorded)."""
    kinematics, q = chain_kinematics(blue, SolverFactory(CLIKSolver, blue, {"gain": 1.0, "damping": 0.01}))
    nu = np.array([0.05, -0.02, 0.01, 0.0, 0.02, -0.03])
    arm = kinematics.arm_rates(0.7, q, nu)
    jacobian, error, feedforward = stacked_terms(kinematics._configuration, [kinematics.task])
    former = arm_rates_for_task(jacobian, error + feedforward, nu, 6, damping=0.01)
    assert np.linalg.norm(former) > 1e-3
    np.testing.assert_allclose(arm, former, rtol=1e-12, atol=1e-15)
    v, result = kinematics._solve(kinematics._configuration, nu, reference=False, diagnostics=True)
    assert np.array_equal(v[:6], nu) and isinstance(result.sigma_min, float)
    assert kinematics.reference_solver is kinematics.arm_solver and kinematics.reference_solver.free_floating


class StackingPriority(PrioritySolver):
    """Task priority declared as not holding its levels: the chain must fix the vehicle's columns instead."""

    holds_priorities = False


def test_the_chain_reads_the_capability_from_the_class_not_the_class_itself(blue):
    """The same method gets a vehicle level on top when it holds priorities (the vehicle's part then nu up to that
    level's DLS damping and the levels below), fixed columns when its class says it does not (exactly nu)."""
    nu = np.array([0.05, -0.02, 0.01, 0.0, 0.02, -0.03])
    parts = {}
    for cls in (PrioritySolver, StackingPriority):
        kinematics, q = chain_kinematics(blue, SolverFactory(cls, blue, {"damping": 0.01, "priority": "classic"}))
        kinematics.arm_rates(0.7, q, nu)
        parts[cls] = kinematics._solve(kinematics._configuration, nu, reference=False, diagnostics=False)[0]
    assert np.array_equal(parts[StackingPriority][:6], nu)
    assert 0.0 < np.abs(parts[PrioritySolver][:6] - nu).max() <= 1e-2 * np.linalg.norm(nu)


def test_a_controller_run_twice_gives_the_same_run(blue):
    """simulate resets the controller: the velocity loop's integral starts at zero on every run (before, a second
    run began with the first one's integral)."""
    plant = uvms.Plant(blue, gravity=True, current=[0.3, 0.0, 0.0])
    thrusters = uvms.dynamics.thrusters_of(blue)
    station = blue.configuration(base=np.zeros(6), arm=ARM)
    actuated = ActuatedPlant(plant, thrusters)
    controller = station_keeping(actuated, station, 0.01, hold_arm=True)
    first, second = (simulate(actuated, controller, station, 0.3, 0.01) for _ in range(2))
    assert np.abs(controller.velocity.integral).max() > 0.0
    np.testing.assert_allclose(second.q, first.q, rtol=0, atol=1e-14)
    np.testing.assert_allclose(second.actuation.thrusts, first.actuation.thrusts, rtol=0, atol=1e-12)


def test_a_plant_refuses_what_it_cannot_apply_and_a_callable_is_not_a_controller():
    robot = shipped("hoang2011")
    with pytest.raises(UVMSError, match=r"Command.arm_torque .* takes Command.arm"):
        simulate(uvms.Plant(robot), OpenLoop(arm_torque=np.zeros(3)), robot.neutral(), 0.02, 0.01)
    with pytest.raises(UVMSError, match=r"Command.thrust .* takes Command.arm"):
        simulate(uvms.Plant(robot), OpenLoop(thrust=np.zeros(2)), robot.neutral(), 0.02, 0.01)
    with pytest.raises(UVMSError, match=r"Command.arm at t = 0 s, which a kinematic plant cannot apply"):
        simulate(robot, OpenLoop(arm=np.zeros(3)), robot.neutral(), 0.02, 0.01)
    with pytest.raises(UVMSError, match=r"reset\(state, t\) and command\(state, t\)"):
        simulate(uvms.Plant(robot), lambda t, q, v: np.zeros(3), robot.neutral(), 0.02, 0.01)


def test_a_solver_reaches_control_in_one_form_and_is_never_compared_by_class():
    """The closing numbers of the interface: no ``is CLIKSolver`` anywhere, SOLVERS[...] looked up once (the
    scenario's solver_class, uvms.scenario.solver), never in control/."""
    package = ROOT / "uvms"
    sources = {path: path.read_text() for path in package.rglob("*.py")}
    assert [path for path, text in sources.items() if re.search(r"is (not )?CLIKSolver", text)] == []
    lookups = [(path.relative_to(package).as_posix(), text.count("SOLVERS[")) for path, text in sources.items()
               if "SOLVERS[" in text]
    assert lookups == [("scenario/solver.py", 1)], lookups
    assert not any(re.search(r"import .*\bSOLVERS\b", text) for path, text in sources.items()
                   if path.parent.name == "control")
