"""uvms.simulate (uvms.sim.loop): one function for the kinematic, passive free-floating and actuated plants; one
immutable result."""

from __future__ import annotations

import dataclasses
import types

import numpy as np
import pinocchio as pin
import pytest

import uvms
from uvms.control import Command, OpenLoop, State
from uvms.control.gjm import GJMController, VelocityRamps
from uvms.dynamics.plant.actuated import ActuatedPlant
from uvms.errors import ConfigurationError, StepCountError, UVMSError
from uvms.sim import SimulationResult, simulate

from conftest import SCENARIOS, shipped

INFO = types.SimpleNamespace(sigma_min=1.0, damping=0.0, limits_active=())


class Never:
    """A controller that must not be asked (what is refused is refused before the run)."""

    def reset(self, state: State, t: float = 0.0) -> None:
        raise AssertionError("nothing may run")

    def command(self, state: State, t: float) -> Command:
        raise AssertionError("nothing may run")


def hoang_run():
    """A kinematic run on hoang2011: a pseudo-inverse law on x, y, yaw towards a moving goal."""
    robot = shipped("hoang2011")
    task = uvms.FrameTask(robot, axes=("x", "y", "yaw"))
    q0 = robot.configuration(base=[0.0, 0.0, 0.0], arm=[1.0, 0.5, 0.2])
    start = robot.fk(q0)

    def goal(t):
        return pin.SE3(start.rotation, start.translation + np.array([0.3 * np.sin(t), 0.2 * t, 0.0]))

    class Law:
        def reset(self, state, t=0.0):
            pass

        def command(self, state, t):
            error = np.array([*(goal(t).translation - robot.fk(state.q).translation)[:2], 0.0])
            return Command(velocity=np.linalg.pinv(robot.jacobian(state.q)[[0, 1, 5]]) @ (2.0 * error), info=INFO)

    return robot, simulate(robot, Law(), q0, 2.0, 0.01, task=task, desired=goal)


def former(*hexes: str) -> np.ndarray:
    """Numbers written on another machine (``float.hex``): compared to rounding, not bit for bit (BLAS and CPUs
    differ in the last place)."""
    return np.array([float.fromhex(value) for value in hexes])


def test_a_kinematic_run_equals_the_former_simulate_to_rounding():
    """The numbers of the former ``uvms.sim.simulate.simulate`` (main before the one simulate) on the same run: 200
    steps of a pseudo-inverse law, each error amplified at most by the closed loop's contraction, so 1e-12
    relative holds on any IEEE machine while a changed formula moves them by far more."""
    robot, result = hoang_run()
    np.testing.assert_allclose(result.q[-1], former(
        "0x1.30602ca34acfbp-3", "0x1.027c22b62653bp-3", "0x1.f9abd5f685664p-1", "0x1.410373aa96d18p-3",
        "0x1.03abead52f08ep+0", "0x1.c2e9bf3dd9dddp-2", "0x1.681e0efb848a0p-4"), rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(result.position_error[-1], former("0x1.923866382de16p-4")[0], rtol=1e-12)
    # the yaw error is a difference of nearby angles (7.6e-4 rad): 1e-9 relative is 1e-12 rad
    np.testing.assert_allclose(result.task_error[-1][0], former("0x1.3d80884f5b400p-9")[0], rtol=1e-9)
    assert result.axes == ("x", "y", "yaw") and result.t.shape == (201,) and result.v.shape == (201, robot.nv)
    assert result.plant is None and result.tracking is None and result.actuation is None


def test_the_task_series_derived_after_the_loop_are_each_rows_own_numbers():
    """The task series from the stored rows: row k's end effector, target and errors as one row at a time computes
    them (FrameTask.full_error_between, log orientation error), as row-major arrays (what trajectory.npz stores)."""
    robot, result = hoang_run()
    task = uvms.FrameTask(robot, axes=("x", "y", "yaw"))
    start = robot.fk(result.q[0])
    for k in (0, 57, 200):
        t, pose = result.t[k], robot.fk(result.q[k])
        goal = pin.SE3(start.rotation, start.translation + np.array([0.3 * np.sin(t), 0.2 * t, 0.0]))
        error = task.full_error_between(goal, pose)
        assert np.array_equal(result.ee_position[k], pose.translation)
        assert np.array_equal(result.desired_rpy[k], pin.rpy.matrixToRpy(goal.rotation))
        assert np.array_equal(result.task_error[k], error[[0, 1, 5]])
        assert result.position_error[k] == np.sqrt(error[:2].dot(error[:2]))
        assert result.orientation_error[k] == abs(error[5])
    for name in ("ee_position", "desired_position", "ee_rpy", "desired_rpy", "task_error"):
        assert getattr(result, name).flags.c_contiguous, name


def test_a_free_floating_rigid_run_conserves_momentum():
    """The GJM controller on the rigid plant, from rest: the momentum stays zero to 1e-9 [N s, N m s]."""
    robot = shipped("hoang2011")
    q0 = robot.configuration(base=[0.0, 0.0, 0.0], arm=[2.0, 0.4, 0.4])
    reference = VelocityRamps.trapezoid(robot.fk(q0).translation, [-0.05, -0.05, 0.0], 2.0, 0.5)
    controller = GJMController(robot, reference, axes=("x", "y"), gain=1.0)
    result = simulate(uvms.Plant(robot, added_mass=False, damping=False), controller, q0, 2.0, 0.005)
    assert np.max(result.plant.momentum_drift()) <= 1e-9  # 9e-11 measured
    assert np.abs(result.plant.momentum).max() <= 1e-9
    assert np.abs(result.v[:, :3]).max() > 1e-3  # the base does move: the arm pushes it around
    tracking = result.tracking
    assert tracking.frame == controller.frame and tracking.position_rows == (0, 1)
    np.testing.assert_array_equal(result.position_error, tracking.position_error)  # no task: the controller's error
    assert result.max_position_error < 6e-3  # 5.3 mm: the 100 ms servos lag (no feedforward)
    assert set(result.plant_arrays()) == set(uvms.sim.result.PLANT_SERIES)


def test_an_actuated_run_equals_the_former_simulate_actuated():
    """Station keeping in a 0.3 m/s current through ``simulate(ActuatedPlant(plant, thrusters), ...)``: the numbers
    of the former ``simulate_actuated`` to 2e-6 relative (issue 31: the arm is re-solved for the task's command
    K e, not J v_ref; the numbers below are the chain's, to rounding), with the former default gains (the defaults now
    scale with the vehicle's inertia) and without what came after it (the reference's acceleration as feedforward,
    the servo's lag compensated, the disturbance observer: issue 48)."""
    robot = shipped("bluerov2_alpha5")
    plant = uvms.Plant(robot, gravity=True, current=[0.3, 0.0, 0.0])
    thrusters = uvms.dynamics.thrusters_of(robot)
    station = robot.configuration(base=np.zeros(6), arm=[3.0, 1.8, 1.8, 1.0, 0.0])
    actuated = ActuatedPlant(plant, thrusters)
    settings = uvms.control.ActuatedSettings(kp=(100, 100, 100, 10, 10, 10), ki=(150, 150, 150, 15, 15, 15),
                                             acceleration_feedforward=False, servo_compensation=False,
                                             disturbance_time_constant=0.0)
    result = simulate(actuated, uvms.control.station_keeping(actuated, station, 0.01, settings), station, 0.5, 0.01)
    # to rounding: 50 steps of the chain (allocation, thruster lag, RK4) carry a last-place difference of the BLAS
    # to about 1e-12 relative in the position, more in the thrusts' sum (a difference of +/- forces of 10 N)
    np.testing.assert_allclose(result.q[-1, :3], former("0x1.36e4baa29f06ap-5", "0x1.b09ab0391adebp-14",
                                                        "-0x1.2be8296055389p-12"), rtol=1e-9, atol=1e-13)
    np.testing.assert_allclose(result.actuation.thrusts[-1].sum(), former("-0x1.9b1b0b576d100p-4")[0], rtol=1e-9,
                               atol=1e-10)
    error = result.actuation.controller["vehicle_position_error"]
    np.testing.assert_allclose(error[-1], former("0x1.36e7487cbb7e4p-5")[0], rtol=1e-9)
    metrics = result.actuation_metrics()
    assert metrics["final_vehicle_position_error"] == error[-1] and 0.0 < metrics["max_thrust_ratio"] <= 1.0
    assert np.all(result.actuation.thrusts <= thrusters.upper) and np.all(result.actuation.thrusts >= thrusters.lower)
    assert result.plant.momentum.shape == (51, 6) and result.tracking is None


def test_a_result_cannot_be_mutated():
    robot, result = hoang_run()
    with pytest.raises(dataclasses.FrozenInstanceError):
        result.q = result.q[::-1]
    with pytest.raises(dataclasses.FrozenInstanceError):
        result.plant = None
    plant_run = simulate(uvms.Plant(robot), OpenLoop(arm=np.ones(robot.n_arm)), robot.neutral(), 0.1, 0.01)
    with pytest.raises(dataclasses.FrozenInstanceError):
        plant_run.plant.command = np.zeros((11, robot.n_arm))
    blue = shipped("bluerov2_alpha5")
    actuated = ActuatedPlant(uvms.Plant(blue), uvms.dynamics.thrusters_of(blue))

    class Custom(OpenLoop):
        def command(self, state, t):
            return Command(arm=np.zeros(blue.n_arm), thrust=np.zeros(actuated.n), info={"custom": t})

    run = simulate(actuated, Custom(), blue.neutral(), 0.02, 0.01)
    with pytest.raises(TypeError):  # the controller's series are read-only
        run.actuation.controller["custom"] = np.zeros(3)
    np.testing.assert_array_equal(run.actuation.controller["custom"], [0.0, 0.01, 0.02])
    assert isinstance(dataclasses.replace(result, axes=()), SimulationResult)  # a new result, the old one unchanged
    assert result.axes == ("x", "y", "yaw")


def test_what_a_system_cannot_run_is_refused_before_it_runs():
    robot = shipped("hoang2011")
    task = uvms.FrameTask(robot, axes=("x", "y"))

    never = Never()
    with pytest.raises(StepCountError, match="control_dt must be 0 for a kinematic run"):
        simulate(robot, never, robot.neutral(), 1.0, 0.1, control_dt=0.2)
    with pytest.raises(StepCountError, match="control_dt must be 0 .* or a positive multiple of dt = 0.1 s"):
        simulate(uvms.Plant(robot), never, robot.neutral(), 1.0, 0.1, control_dt=0.15)
    with pytest.raises(UVMSError, match="task and desired go together"):
        simulate(robot, never, robot.neutral(), 1.0, 0.1, task=task)
    with pytest.raises(ConfigurationError, match="a kinematic run has no velocity state"):
        simulate(robot, never, robot.neutral(), 1.0, 0.1, v0=np.zeros(robot.nv))
    blue = shipped("bluerov2_alpha5")
    with pytest.raises(ConfigurationError, match="thrusts0 .* must lie within"):
        ActuatedPlant(uvms.Plant(blue), uvms.dynamics.thrusters_of(blue), thrusts0=np.full(8, 1e6))
    with pytest.raises(StepCountError, match="runs once per step"):
        simulate(ActuatedPlant(uvms.Plant(blue), uvms.dynamics.thrusters_of(blue)), never, blue.neutral(), 1.0, 0.1,
                 control_dt=0.2)
    with pytest.raises(UVMSError, match="recorded extra, which no series of SimulationResult holds"):
        simulate(robot, OpenLoop(velocity=np.zeros(robot.nv), info=INFO), robot.neutral(), 0.1, 0.1,
                 recorders=[lambda t, q, x, sample: {"extra": 1.0}])


def test_the_rows_are_gathered_by_name_in_order_including_a_name_some_rows_lack():
    """run_loop keeps the rows as they come and gathers them after the loop: each series in row order, the names in
    the order they first came, a name missing from some rows gathered from the rows that have it."""
    from uvms.sim.loop import gathered

    rows = [{"t": 0.0, "q": np.zeros(2)}, {"t": 0.1, "q": np.ones(2)}]
    series = gathered(rows)
    assert list(series) == ["t", "q"] and series["t"].tolist() == [0.0, 0.1]
    assert series["q"].tolist() == [[0.0, 0.0], [1.0, 1.0]]
    uneven = gathered([{"t": 0.0}, {"t": 0.1, "extra": 3.0}, {"extra": 4.0, "t": 0.2}])
    assert list(uneven) == ["t", "extra"] and uneven["extra"].tolist() == [3.0, 4.0]
    assert uneven["t"].tolist() == [0.0, 0.1, 0.2] and gathered([]) == {}


def test_a_controller_s_stage_velocity_gives_the_rows_of_its_command_bit_for_bit():
    """The kinematic run asks a controller with ``stage_velocity`` for v alone at the RK4 stages (no command, no
    diagnostics): the run's rows equal those of the same controller asked only through ``command``; the CLIK's
    prepared frame step (hoang2011_w1) and the set-based solver, whose rows the recorder shares, through command."""
    from uvms.scenario.build import build
    from uvms.scenario.schema import read_scenario

    class CommandOnly:
        """The controller as one without stage_velocity."""

        def __init__(self, controller):
            self.reset, self.command = controller.reset, controller.command

    for path in ("hoang2011_w1.toml", "hoang2011_w1_set_based.toml"):
        setup = build(read_scenario(SCENARIOS / path, []))
        runs = [simulate(setup.robot, controller, setup.q0, 3.0, 0.02, progress=False)
                for controller in (setup.controller, CommandOnly(setup.controller))]
        assert hasattr(setup.controller, "stage_velocity") and not hasattr(CommandOnly, "stage_velocity")
        for name in ("q", "v", "sigma_min", "damping"):
            assert np.array_equal(getattr(runs[0], name), getattr(runs[1], name)), (path, name)
        assert np.ptp(runs[0].q[:, 0]) > 1e-3  # the vehicle moved
