"""Any solver of uvms.solvers.SOLVERS, with [[inequalities]], on the passive free-floating (GJM) plant (issue 31)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import uvms
from uvms.control.gjm import GJMControlError, GJMController, VelocityRamps
from uvms.scenario import ScenarioError, run_scenario
from uvms.solvers import ConstraintSolver, SetBasedSolver
from uvms.solvers.base import SolverFactory
from uvms.tasks.objectives import JointLimits

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = ROOT / "scenarios"
NO_FIGURES = ["outputs.figures=false"]
#: hoang2011_gjm (rigid plant, gravity off, no thrusters, servo feedforward on) at dt 2.5 ms for 2 s (RK4:
#: set_based's drift 9e-11 N s, 1.5e-9 at 5 ms).
FINE = [*NO_FIGURES, "simulation.dt=0.0025", "simulation.duration=2.0"]
#: a digital controller (the command held over each step): the QP's solution, exact only to its tolerance, then
#: does not enter RK4's stages (continuous, hqp's drift is 2.5e-5 N s)
DIGITAL = ["plant.control_dt=0.0025"]
NO_VARIABLE_DAMPING = ["solver.damping_epsilon=0", "solver.damping_max=0"]


def hoang(tmp_path: Path, extra: str = "") -> Path:
    """hoang2011_gjm.toml with the model's absolute path and ``extra`` tables appended."""
    text = (SCENARIOS / "hoang2011_gjm.toml").read_text()
    text = text.replace('path = "../models/', f'path = "{ROOT}/models/')
    path = tmp_path / "hoang2011_gjm_limits.toml"
    path.write_text(text.replace("[plant]", f"{extra}\n[plant]"))
    return path


#: q1 goes from 2.0 to 1.694 rad in the first 2 s of hoang2011_gjm: a valid set q1 >= 1.75 rad is reached...
ACTIVE = '[[inequalities]]\ntype = "joint_limits"\njoints = ["q1"]\nmargin = 1.75\nband = 0.1\n'
#: ... q1 >= 0.5 rad (band 0.2) never is.
INACTIVE = '[[inequalities]]\ntype = "joint_limits"\njoints = ["q1"]\nmargin = 0.5\nband = 0.2\n'


#: hqp's rates chatter at the joint's bound (issue 31, defect 3): its drift then shrinks as dt^3, not RK4's dt^4
#: (9.5e-8 N s at dt 5 ms, 1.2e-8 at 2.5 ms); with the limit inactive it is below 1e-9 like every method.
CHATTER_BOUND = 1e-7


@pytest.mark.parametrize(("method", "overrides", "table", "bound"), [
    ("clik", [], ACTIVE, 1e-9),
    ("task_priority", NO_VARIABLE_DAMPING, ACTIVE, 1e-9),
    ("set_based", [], ACTIVE, 1e-9),
    ("hqp", NO_VARIABLE_DAMPING, INACTIVE, 1e-9),
    ("hqp", NO_VARIABLE_DAMPING, ACTIVE, CHATTER_BOUND),
])
def test_every_method_conserves_momentum_on_the_rigid_plant(tmp_path, method, overrides, table, bound):
    result = run_scenario(hoang(tmp_path, table), out=tmp_path / "out", progress=False,
                          overrides=[*FINE, *DIGITAL, f"solver.method={method}", *overrides])
    metrics = result.metrics
    assert metrics["plant"] == "rigid" and metrics["steps"] == 800
    assert max(metrics["momentum_drift"]) < bound  # [N s, N m s]: thrusters off, gravity off: h = 0 kept
    assert metrics["vehicle_travel"] > 1e-3  # the vehicle really moves in reaction
    entry = metrics["inequalities"]["joint_limits"]
    assert metrics["inequalities_enforced"] is (method in ("set_based", "hqp"))
    if table == INACTIVE:
        assert entry["active_fraction"] == 0.0
    elif method in ("set_based", "hqp"):  # q1 held at the valid set 1.75 rad (hqp: 0.05 mrad past it, the servo)
        assert entry["max_violation"] < 1e-4 and entry["active_fraction"] > 0.2
    else:  # monitored: q1 goes on to 1.694 rad
        assert entry["max_violation"] > 0.04


def test_set_based_with_its_limits_inactive_is_clik_with_the_servo_feedforward(tmp_path):
    """Inactive objectives: set_based is CLIK to rounding, and so is the feedforward (the objectives' share fed
    no task velocity is zero)."""
    path = hoang(tmp_path, INACTIVE)
    clik = run_scenario(path, out=tmp_path / "clik", progress=False, overrides=FINE).simulation
    set_based = run_scenario(path, out=tmp_path / "sb", progress=False,
                             overrides=[*FINE, "solver.method=set_based"]).simulation
    assert np.max(np.abs(clik.q - set_based.q)) < 1e-9
    assert np.max(np.abs(clik.position_error - set_based.position_error)) < 1e-10
    assert clik.position_error.max() < 1e-6  # the feedforward inverts the servo: the rigid plant tracks exactly


@pytest.fixture(scope="module")
def limits_runs(tmp_path_factory):
    """Scenario (c): amundsen2018's closed loop with set-based joint limits, and the same with CLIK (monitored)."""
    out = tmp_path_factory.mktemp("limits")
    path = SCENARIOS / "amundsen2018_hydro_closed_loop_limits.toml"
    return {method: run_scenario(path, out=out / method, overrides=[*NO_FIGURES, f"solver.method={method}"],
                                 progress=False).metrics for method in ("set_based", "clik")}


def test_set_based_keeps_the_joint_limits_that_clik_leaves(limits_runs):
    kept, left = limits_runs["set_based"], limits_runs["clik"]
    assert kept["plant"] == "hydrodynamic" and kept["inequalities_enforced"] and not left["inequalities_enforced"]
    kept_entry, left_entry = kept["inequalities"]["joint_limits"], left["inequalities"]["joint_limits"]
    assert kept_entry["max_violation"] == 0.0 and kept_entry["active_fraction"] > 0.4  # active from t = 3.9 s
    assert kept_entry["value_range"][0] == pytest.approx(-1.0466, abs=1e-3)  # the wrist stops at -1.047 rad
    valid = -np.pi / 2 + 0.5
    assert kept_entry["value_range"][0] > valid > left_entry["value_range"][0]
    assert left_entry["max_violation"] == pytest.approx(0.1356, abs=1e-3)  # CLIK: joint 8 to -1.206 rad
    assert left["max_position_error"] == pytest.approx(5.889e-3, abs=1e-6)  # amundsen2018_hydro_closed_loop's
    assert kept["max_position_error"] == pytest.approx(8.77e-3, abs=1e-4)  # the task pays: 8.8 mm, under 1 cm
    assert kept["final_position_error"] == pytest.approx(6.38e-3, abs=1e-4)


# ------------------------------------------------------------------ what a passive vehicle refuses
@pytest.mark.parametrize(("overrides", "words"), [
    (["solver.free_floating=false"], r"leaves the vehicle passive \(no actuators\).*set solver.free_floating = true.*"
                                     r"plant.thrusters = true.*plant.type = 'kinematic'"),
    (["solver.method=task_priority", *NO_VARIABLE_DAMPING, "vehicle.heading=0.3"],
     r"a \[vehicle\] task cannot be followed; remove it.*or set plant.thrusters = true"),
    (["solver.method=kinematic_constraint", *NO_VARIABLE_DAMPING],
     r"needs 2 levels, the first of them a constraint.*a passive vehicle cannot follow"),
    (["solver.alpha=1.0"], r"\[\[inequalities\]\] table of type 'joint_limits'.*'set_based' or 'hqp'"),
])
def test_what_a_passive_vehicle_cannot_do_is_refused(tmp_path, overrides, words):
    with pytest.raises(ScenarioError, match=words):
        run_scenario(SCENARIOS / "hoang2011_gjm.toml", out=tmp_path, overrides=[*NO_FIGURES, *overrides],
                     progress=False)
    assert not tmp_path.exists() or not any(tmp_path.iterdir())


def test_the_controller_refuses_levels_a_solver_would_not_use():
    robot = uvms.load(ROOT / "models/hoang2011/uvms.urdf.xacro")
    reference = VelocityRamps.trapezoid(np.zeros(3), np.array([0.05, 0.0, 0.0]), 4.0, 1.0)
    with pytest.raises(GJMControlError, match="need a solver that enforces inequalities"):
        GJMController(robot, reference, axes=("x", "y"), levels=[JointLimits(robot)])
    with pytest.raises(GJMControlError, match="ConstraintSolver needs 2 levels"):
        GJMController(robot, reference, axes=("x", "y"), solver=SolverFactory(ConstraintSolver, robot))
    with pytest.raises(GJMControlError, match="SetBasedSolver takes no 'regularization'"):
        GJMController(robot, reference, axes=("x", "y"),
                      solver=SolverFactory(SetBasedSolver, robot, {"regularization": 1.0}))
    controller = GJMController(robot, reference, axes=("x", "y"), gain=1.0,
                               solver=SolverFactory(SetBasedSolver, robot, {"dt": 0.01}),
                               levels=[JointLimits(robot, margin=0.1)])
    q = robot.configuration(arm=np.array([2.0, 0.4, 0.4]))
    sample = controller.sample(q, 2.0)
    plain = GJMController(robot, reference, axes=("x", "y"), gain=1.0).sample(q, 2.0)
    assert np.allclose(sample.rates, plain.rates, atol=1e-12)  # far from the limits: the CLIK rates
