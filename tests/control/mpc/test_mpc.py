"""The whole-body MPC on Crocoddyl (uvms.control.mpc): the action model against the plant (one step, derivatives),
a Box-FDDP solve, and a short closed loop on the actuated BlueROV2 + Alpha 5 in a current it does not know."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pinocchio as pin
import pytest

from uvms.control.mpc import require_crocoddyl
from uvms.control.mpc.settings import MPCSettings
from uvms.dynamics.plant.actuated import ActuatedPlant
from uvms.dynamics.plant.command import State
from uvms.dynamics.plant.plant import Plant
from uvms.dynamics.thrusters.thrusters import thrusters_of
from uvms.errors import UVMSError
from uvms.numerics.integrate import rk4_step
from uvms.sim import simulate

from conftest import ROOT, shipped

crocoddyl = pytest.importorskip("crocoddyl", reason="the mpc extra (Crocoddyl) is not installed")

ARM = [3.0, 1.8, 1.8, 1.0, 0.0]  # the arm reaching forward and down, away from its limits
CURRENT = np.array([-0.3, 0.0, 0.0])  # [m/s] from ahead


def plant() -> Plant:
    return Plant(shipped("bluerov2_alpha5"), gravity=True, current=CURRENT, motor_time_constant=0.1)


def controller(settings: MPCSettings, target=None, the_plant: Plant | None = None):
    from uvms.control.mpc.controller import MPCController

    the_plant = plant() if the_plant is None else the_plant
    robot = the_plant.robot
    q0 = robot.configuration(base=[0.0, 0.0, -5.0, 0.0, 0.0, 0.0], arm=ARM)
    start = robot.fk(q0).translation
    target = (lambda t: start) if target is None else target(start)
    mpc = MPCController(the_plant, thrusters_of(robot), target, settings=settings)
    mpc.reset(State(q0))
    return mpc, q0


def test_importing_the_package_loads_no_crocoddyl():
    code = "import uvms.control.mpc, uvms.control.mpc.settings, uvms.control.mpc.prediction, sys; " \
           "print('crocoddyl' in sys.modules)"
    output = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    assert output.stdout.strip() == "False"


def test_without_crocoddyl_the_error_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "crocoddyl", None)  # import crocoddyl raises ImportError
    with pytest.raises(UVMSError, match=r"pip install 'uvms\[mpc\]'"):
        require_crocoddyl()


@pytest.mark.parametrize(("key", "value", "match"), [("horizon", 0, "horizon"), ("node_dt", 0.0, "node_dt"),
                                                     ("integrator", "rk2", "euler, rk4"), ("thrust", -1.0, "thrust"),
                                                     ("saturation_onset", 1.0, r"saturation_onset .*\(0, 1\)"),
                                                     ("saturated_task_share", 0.0, r"\(0, 1\]")])
def test_settings_refuse_what_is_not_valid(key, value, match):
    with pytest.raises(UVMSError, match=match):
        MPCSettings(**{key: value})


def test_one_rk4_node_is_the_plants_rk4_step_with_the_same_current(rng):
    """The prediction (knows_current) stepped by Crocoddyl's RK4 over 0.01 s = uvms's RK4 (Munthe-Kaas) step of
    the plant under the same held thrusts and arm command, to 1e-6; its calc is the plant's acceleration."""
    mpc, q0 = controller(MPCSettings(horizon=2, node_dt=0.01, integrator="rk4", knows_current=True))
    model = mpc.problem.runningModels[0]
    data = model.createData()
    v = rng.normal(size=q0.size - 1) * 0.2
    u = np.concatenate([rng.uniform(-20.0, 20.0, 8), rng.normal(size=5) * 0.2])
    model.calc(data, np.concatenate([q0, v]), u)
    the_plant = mpc.prediction.plant
    wrench = mpc.prediction.matrix @ u[:8]

    def rate(t, q, x):
        return x, the_plant.dynamics(q, x, u[8:], wrench).acceleration

    q1, v1 = rk4_step(the_plant.model, rate, 0.0, q0, v, 0.01, rate(0.0, q0, v))
    np.testing.assert_allclose(data.xnext[:q0.size], q1, rtol=0, atol=1e-6)
    np.testing.assert_allclose(data.xnext[q0.size:], v1, rtol=0, atol=1e-6)
    assert np.abs(v1 - v).max() > 1e-3  # the step moved
    differential = mpc.nodes[0][1]
    ddata = differential.createData()
    differential.calc(ddata, np.concatenate([q0, v]), u)
    np.testing.assert_allclose(ddata.xout, the_plant.dynamics(q0, v, u[8:], wrench).acceleration, atol=1e-12)


def test_the_nodes_derivatives_match_crocoddyls_finite_differences(rng):
    """The whole Euler node (dynamics and costs: Fx, Fu, Lx, Lu) against Crocoddyl's ActionModelNumDiff (the
    dynamics alone: test_prediction.py, to 1e-6 against central differences)."""
    mpc, q0 = controller(MPCSettings(horizon=2, node_dt=0.05))
    model = mpc.problem.runningModels[0]
    numeric = crocoddyl.ActionModelNumDiff(model, True)
    x = np.concatenate([q0, rng.normal(size=q0.size - 1) * 0.2])
    u = np.concatenate([rng.uniform(-20.0, 20.0, 8), rng.normal(size=5) * 0.2])
    data, numeric_data = model.createData(), numeric.createData()
    model.calc(data, x, u)
    model.calcDiff(data, x, u)
    numeric.calc(numeric_data, x, u)
    numeric.calcDiff(numeric_data, x, u)
    for name in ("Fx", "Fu", "Lx", "Lu"):
        analytical, finite = getattr(data, name), getattr(numeric_data, name)
        assert np.abs(finite).max() > 1e-3, name
        # forward differences (Crocoddyl's) of costs with weights up to 1e5: agreement to 1e-3 of the largest entry
        np.testing.assert_allclose(analytical, finite, rtol=0, atol=1e-3 * np.abs(finite).max(), err_msg=name)


def test_a_solve_from_rest_holds_the_thrusts_within_their_bounds():
    """A CSQP solve runs (a broken Pinocchio/Crocoddyl pair crashes here) and its inputs are finite and within the
    thrusters' and the joints' bounds at every node (to the ADMM's tolerance; the applied command exactly)."""
    mpc, q0 = controller(MPCSettings(horizon=10, node_dt=0.1, iterations=5),
                         target=lambda start: (lambda t: start + np.array([0.0, 0.1, 0.0])))
    command = mpc.command(State(q0, np.zeros(q0.size - 1)), 0.0)
    thrusters = thrusters_of(shipped("bluerov2_alpha5"))
    assert np.all(np.isfinite(command.thrust)) and np.abs(command.thrust).max() > 1.0
    for u in [u.copy() for u in mpc.solver.us]:
        assert np.all(u >= mpc.lower - 1e-3) and np.all(u <= mpc.upper + 1e-3)
    assert np.all(command.thrust >= thrusters.lower) and np.all(command.thrust <= thrusters.upper)
    assert mpc.iterations[0] >= 1 and np.isfinite(mpc.solver.cost)


def test_the_lag_compensation_gives_the_planned_thrust_as_the_mean_over_the_period():
    """From thrusters at rest, the command's first-order response averages the planned thrust over the control
    period (what the prediction applies over a node), not only reaches it at the period's end."""
    settings = MPCSettings(horizon=10, node_dt=0.1, control_period=0.05)
    mpc, q0 = controller(settings, target=lambda start: (lambda t: start + np.array([0.0, 0.1, 0.0])))
    measured = np.full(8, 1.0)
    command = mpc.command(State(q0, np.zeros(q0.size - 1), measured), 0.0)
    planned, tau, h = mpc._us[0][:8], mpc.time_constants, 0.05  # the plan's first thrusts
    inside = ((command.thrust > mpc.lower[:8] + 1e-9) & (command.thrust < mpc.upper[:8] - 1e-9)
              & (planned > mpc.lower[:8]) & (planned < mpc.upper[:8]))
    assert inside.sum() >= 4 and np.abs(planned[inside] - measured[inside]).max() > 0.5
    t = np.linspace(0.0, h, 2001)[:, None]
    response = command.thrust + (measured - command.thrust) * np.exp(-t / tau)  # the thrusters' first-order lag
    mean = (response[:-1] + response[1:]).sum(axis=0) / 2 / (t.size - 1)  # trapezoid mean over the period
    np.testing.assert_allclose(mean[inside], planned[inside], atol=1e-4)


def test_the_targets_out_of_reach_are_brought_within_reach_of_the_end_effector():
    """A trajectory 1 m away: the nodes' targets are 5 cm from the measured end effector, towards the trajectory's
    points; with end_effector_reach = 0 they are the trajectory's."""
    far = lambda start: (lambda t: start + np.array([1.0, 0.1 * t, 0.0]))  # noqa: E731
    mpc, q0 = controller(MPCSettings(horizon=4, node_dt=0.1), target=far)
    x0 = np.concatenate([q0, np.zeros(q0.size - 1)])
    here = mpc.robot.fk(q0).translation
    for index, target in enumerate(mpc._targets(x0, 0.0)):
        wanted = mpc.target(0.1 * index)
        np.testing.assert_allclose(np.linalg.norm(target - here), 0.05)
        np.testing.assert_allclose((target - here) / 0.05, (wanted - here) / np.linalg.norm(wanted - here))
    mpc, q0 = controller(MPCSettings(horizon=4, node_dt=0.1, end_effector_reach=0.0), target=far)
    np.testing.assert_allclose(mpc._targets(x0, 0.2)[1], mpc.target(0.3))


def test_the_closed_loop_keeps_the_jaws_on_a_moving_target_in_an_unknown_current():
    """0.6 s on the actuated plant (thrusters with their lag, 0.3 m/s current the MPC does not know): the jaws
    follow a target moving 5 cm/s sideways within 1.5 cm, the thrusts inside their bounds at every step."""
    mpc, q0 = controller(MPCSettings(horizon=10, node_dt=0.1),
                         target=lambda start: (lambda t: start + np.array([0.0, 0.05 * t, 0.0])))
    the_plant = plant()
    thrusters = thrusters_of(the_plant.robot)
    result = simulate(ActuatedPlant(the_plant, thrusters), mpc, q0, 0.6, 0.01, progress=False)
    frame = the_plant.robot.frame_id()
    errors = []
    for t, q in zip(result.t, result.q):
        pin.framesForwardKinematics(the_plant.model, the_plant.data, q)
        desired = mpc.target(t)
        errors.append(np.linalg.norm(the_plant.data.oMf[frame].translation - desired))
    thrusts = result.actuation.thrusts
    # measured: 0.43 cm, 0.07 cm (0.93 cm, 0.29 cm with the lag compensation aiming at the period's end and a
    # filtered first estimate)
    assert max(errors) < 0.006 and errors[-1] < 0.002
    assert np.all(thrusts >= thrusters.lower - 1e-9) and np.all(thrusts <= thrusters.upper + 1e-9)
    assert len(mpc.solve_times) == 13  # every 0.05 s from 0 to 0.6 s (the period's default; the last row's too)
    assert mpc.prediction.disturbance[0] < -5.0  # the unknown current's drag from ahead, estimated: -16.3 N


ABORTING = """
import numpy as np
from uvms import load
from uvms.control.mpc.controller import MPCController
from uvms.control.mpc.settings import MPCSettings
from uvms.dynamics.plant.command import State
from uvms.dynamics.plant.plant import Plant
from uvms.dynamics.thrusters.thrusters import thrusters_of

robot = load("models/bluerov2_alpha5/uvms.urdf.xacro")
q0 = robot.configuration(base=[0.0, 0.0, -5.0, 0.0, 0.0, 0.0], arm=[3.0, 1.8, 1.8, 1.0, 0.0])
start = robot.fk(q0).translation
mpc = MPCController(Plant(robot, gravity=True, motor_time_constant=0.1), thrusters_of(robot), lambda t: start,
                    settings=MPCSettings(horizon=3, node_dt=0.1))
mpc.reset(State(q0))
xs = [x.copy() for x in mpc._xs]
xs[2][:3] = np.nan  # a node out of range, as a diverged QP step leaves a line-search trial
mpc.problem.x0 = xs[0]
mpc.solver.solve(xs, list(mpc._us), 1, False)
print("returned", np.isfinite(mpc.solver.cost))
"""


def test_a_node_out_of_range_is_rejected_not_the_process_aborted():
    """A warm start (or a line-search trial) with a non-finite state: the node reports a large finite cost, every
    row violated and no acceleration. Before, the NaN it evaluated to threw inside CSQP's OpenMP loop (Crocoddyl's
    check of a trial's cost, or a Python exception from the node), which no handler catches: the process aborted
    (`terminate called after throwing ... crocoddyl::Exception`, `step_error`)."""
    output = subprocess.run([sys.executable, "-c", ABORTING], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert output.returncode == 0, output.stderr[-500:]
    assert output.stdout.strip() == "returned True"


def test_a_node_reports_a_point_out_of_range_as_rejected():
    """calc at a state or input beyond UNBOUNDED (or NaN): REJECTED_COST (below Crocoddyl's 1e30), no acceleration,
    every row violated; calcDiff there is flat. A point in range is evaluated as before."""
    from uvms.control.mpc.action import REJECTED_COST
    from uvms.control.mpc.constraints import UNBOUNDED

    mpc, q0 = controller(MPCSettings(horizon=2, node_dt=0.1))
    model = mpc.nodes[1][1]
    data = model.createData()
    x, u = np.concatenate([q0, np.zeros(q0.size - 1)]), np.zeros(mpc.prediction.nu)
    for bad_x, bad_u in ((x, np.full_like(u, 2.0 * UNBOUNDED)), (np.where(np.arange(x.size) == 4, np.nan, x), u)):
        model.calc(data, bad_x, bad_u)
        assert data.rejected and data.cost == REJECTED_COST and not data.xout.any()
        assert np.all(data.g >= model.g_ub + 0.5 * UNBOUNDED)
        model.calcDiff(data, bad_x, bad_u)
        assert not data.Fx.any() and not data.Lx.any()
    model.calc(data, x, u)
    assert not data.rejected and 0.0 < data.cost < 1e10 and np.abs(data.xout).max() > 0.1  # it sinks or floats


def test_a_node_whose_plant_solve_fails_is_rejected_not_raised(monkeypatch):
    """The acceleration is the plant's call, whose vehicle solve raises NumericalError on a non-finite solution: at
    such a trial point the node is rejected (as a non-finite acceleration was), no exception leaves calc (it would
    abort the process inside CSQP's OpenMP loop)."""
    from uvms.control.mpc.action import REJECTED_COST
    from uvms.errors import NumericalError

    mpc, q0 = controller(MPCSettings(horizon=2, node_dt=0.1))
    model = mpc.nodes[1][1]
    data = model.createData()
    x, u = np.concatenate([q0, np.zeros(q0.size - 1)]), np.zeros(mpc.prediction.nu)

    def singular(*_):
        raise NumericalError("singular or overflowing 6x6 system")

    monkeypatch.setattr(mpc.prediction, "evaluate", singular)
    model.calc(data, x, u)
    assert data.rejected and data.cost == REJECTED_COST and not data.xout.any()


def test_the_warm_start_is_the_last_plan_read_at_the_nodes_times():
    """Half a node after a solve (20 Hz, 0.1 s nodes) the warm start's nodes lie midway between the plan's (the
    inputs linearly, the states along the manifold); a whole node later they are the plan shifted by one, the last
    node held. (A round(0.5) shift was 0 or 1 by floating point, from one solve to the next.)"""
    mpc, q0 = controller(MPCSettings(horizon=4, node_dt=0.1))
    rng = np.random.default_rng(3)
    mpc._us = [rng.normal(size=mpc.prediction.nu) for _ in range(4)]
    mpc._xs = [np.concatenate([pin.integrate(mpc.robot.model, q0, 0.1 * k * np.ones(q0.size - 1)),
                               np.full(q0.size - 1, float(k))]) for k in range(5)]
    mpc._solved_at = 1.0
    xs, us = mpc._warm_start(1.05)
    np.testing.assert_allclose(us[1], 0.5 * (mpc._us[1] + mpc._us[2]), atol=1e-12)
    np.testing.assert_allclose(xs[2][q0.size:], 2.5, atol=1e-12)
    np.testing.assert_allclose(mpc.state.diff(mpc._xs[1], xs[1])[:q0.size - 1], 0.05, atol=1e-9)
    np.testing.assert_allclose(us[3], mpc._us[3])  # beyond the last input: held
    xs, us = mpc._warm_start(1.1 + 1e-12)
    np.testing.assert_allclose(us[0], mpc._us[1], atol=1e-9)
    np.testing.assert_allclose(xs[3], mpc._xs[4], atol=1e-9)
    np.testing.assert_allclose(xs[4], mpc._xs[4], atol=1e-9)


def test_the_task_gives_way_when_holding_still_asks_more_than_the_thrusters_range():
    """The end effector's weights: whole while holding still asks less than saturation_onset of the thrusters'
    range (a 0.3 m/s current), saturated_task_share of them from the whole range on (1.0 m/s),
    geometrically between; known currents and estimated wrenches count alike."""
    from uvms.control.mpc.controller import MPCController

    settings = MPCSettings(horizon=2, node_dt=0.1, knows_current=True)
    mpc, q0 = controller(settings)
    x0 = np.concatenate([q0, np.zeros(q0.size - 1)])
    assert mpc._task_share(x0) == 1.0 and 0.05 < mpc.saturation < 0.8
    strong = Plant(shipped("bluerov2_alpha5"), gravity=True, current=np.array([-1.0, 0.0, 0.0]),
                   motor_time_constant=0.1)
    mpc, q0 = controller(settings, the_plant=strong)
    assert mpc._task_share(x0) == pytest.approx(1e-3) and mpc.saturation > 1.0
    still = MPCController(plant(), thrusters_of(plant().robot), lambda t: np.zeros(3),
                          settings=MPCSettings(horizon=2, node_dt=0.1))  # still water predicted
    still.reset(State(q0))
    still.prediction.disturbance = np.array([-100.0, 0.0, 0.0, 0.0, 0.0, 0.0])  # an estimate of 100 N from ahead
    share = still._task_share(x0)
    assert 1e-3 < share < 1.0 and 0.8 < still.saturation < 1.0
    np.testing.assert_allclose(share, 1e-3 ** ((still.saturation - 0.8) / 0.2))
    for costs, _ in still.nodes:
        costs.weigh_task(share)
    assert still.nodes[0][0].end_effector.weight == pytest.approx(share * 1e4)
