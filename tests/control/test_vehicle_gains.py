"""Vehicle-control gains that fit the vehicle (uvms.control.vehicle.velocity_gains, vehicle_inertia): the shipped
BlueROV2 + Alpha 5 (11.5 kg) and a RexROV-sized vehicle (1863 kg, tests/fixtures/rexrov_like) hold station with the
default bandwidth and damping ratio; the BlueROV2-sized gains of before leave the RexROV drifting."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import uvms
from uvms.control.settings import DEFAULT_BANDWIDTH, DEFAULT_DAMPING_RATIO, ActuatedSettings
from uvms.control.station import station_keeping
from uvms.control.vehicle import vehicle_inertia, velocity_gains
from uvms.dynamics.plant.actuated import ActuatedPlant
from uvms.dynamics.plant.plant import Plant
from uvms.dynamics.thrusters.thrusters import thrusters_of
from uvms.errors import SolverInputError
from uvms.sim import simulate

from conftest import ROOT

DT = 0.01
#: The hand-tuned gains that were the defaults: right for the BlueROV2, 100 times too small for the RexROV.
BLUEROV_SIZED = {"kp": [100.0, 100.0, 100.0, 10.0, 10.0, 10.0], "ki": [150.0, 150.0, 150.0, 15.0, 15.0, 15.0]}


@pytest.fixture(scope="module")
def vehicles() -> dict:
    """name -> (robot, thrusters, arm at the station)."""
    bluerov = uvms.load("bluerov2_alpha5")
    rexrov = uvms.load(str(ROOT / "tests" / "fixtures" / "rexrov_like" / "rexrov_like.urdf"), ee="tool")
    return {"bluerov2": (bluerov, thrusters_of(bluerov), [3.0, 1.8, 1.8, 1.0, 0.0]),
            "rexrov": (rexrov, thrusters_of(rexrov), [0.0, 0.5, 0.5, 0.0, 0.02])}


def test_the_gains_place_the_velocity_loop_poles():
    """kp = 2 zeta omega M, ki = omega^2 M: the roots of M s^2 + kp s + ki are -zeta omega +- omega sqrt(zeta^2 - 1)."""
    inertia = np.array([1970.0, 3112.0, 5550.0, 1091.0, 1734.0, 982.0])
    kp, ki = velocity_gains(inertia, [2.0, 3.0, 1.0, 5.0, 4.0, 6.0], [0.5, 0.9, 1.0, 1.5, 0.7, 2.0])
    for i, (omega, zeta) in enumerate(zip([2.0, 3.0, 1.0, 5.0, 4.0, 6.0], [0.5, 0.9, 1.0, 1.5, 0.7, 2.0])):
        roots = np.sort_complex(np.roots([inertia[i], kp[i], ki[i]]))
        expected = np.sort_complex(-zeta * omega + omega * np.array([-1.0, 1.0]) * np.emath.sqrt(zeta**2 - 1.0))
        np.testing.assert_allclose(roots, expected, atol=1e-6 * omega)
    np.testing.assert_allclose(velocity_gains(np.ones(6), 2.0, 1.0), [np.full(6, 4.0), np.full(6, 4.0)])


@pytest.mark.parametrize("bandwidth, damping_ratio, message", [
    (0.0, 1.0, "bandwidth must be a number or 6 numbers > 0"),
    ([1.0, 2.0], 1.0, "bandwidth must be a number or 6 numbers > 0"),
    (1.0, -0.5, "damping_ratio must be a number or 6 numbers > 0"),
    (1.0, np.nan, "damping_ratio must be a number or 6 numbers > 0"),
])
def test_a_bandwidth_or_damping_ratio_that_is_not_positive_is_refused(bandwidth, damping_ratio, message):
    with pytest.raises(SolverInputError, match=message):
        velocity_gains(np.ones(6), bandwidth, damping_ratio)


def test_the_inertia_is_the_kinetic_energy_of_a_unit_body_twist(vehicles, monkeypatch):
    """M_ii = 2 T(e_i): the plant's kinetic energy (rigid + added mass, the arm included) of a unit twist of the base
    frame along axis i, mapped to the vehicle joint; here with a base frame that is not the joint's frame (a URDF
    puts a link's frame on its joint, so the robot's base placement is replaced for the test)."""
    robot, _, arm = vehicles["rexrov"]
    placement = pin.SE3(pin.rpy.rpyToMatrix(0.1, -0.2, 0.3), np.array([0.4, -0.1, 0.2]))
    monkeypatch.setattr(type(robot), "base_placement", property(lambda self: placement.copy()))
    plant = Plant(robot, gravity=True)
    q = robot.configuration(base=[1.0, 2.0, -20.0, 0.05, -0.1, 0.7], arm=arm)
    inertia = vehicle_inertia(plant, q)
    for i in range(6):
        joint_twist = placement.act(pin.Motion(np.eye(6)[i])).vector
        kinetic, _ = plant.energy(q, np.concatenate([joint_twist, np.zeros(robot.n_arm)]))
        assert inertia[i] == pytest.approx(2.0 * kinetic, rel=1e-12)
    assert inertia[0] > 1862.87 + 79.79  # rigid + added surge mass, the arm on top


def _recovery(robot, thrusters, arm, gains) -> tuple[np.ndarray, np.ndarray]:
    """Still water, arm held: started 0.1 m and 0.05 rad off station, the errors over 4 s divided by those."""
    plant = Plant(robot, gravity=True)
    station = robot.configuration(base=[0.0, 0.0, -5.0, 0.0, 0.0, 0.0], arm=arm)
    start = robot.configuration(base=[0.1, 0.0, -5.0, 0.0, 0.0, 0.05], arm=arm)
    actuated = ActuatedPlant(plant, thrusters)
    controller = station_keeping(actuated, station, DT, ActuatedSettings(**gains), hold_arm=True)
    series = simulate(actuated, controller, start, 4.0, DT).actuation.controller
    return series["vehicle_position_error"] / 0.1, series["vehicle_attitude_error"] / 0.05


def test_both_vehicles_recover_alike_with_the_default_gains(vehicles):
    """The gains scale with the inertia, so the closed loop (s^3 + 2 zeta omega s^2 + (2 zeta omega K + omega^2) s
    + omega^2 K with the pose gain K) does not depend on the vehicle: the normalized recoveries of an 11.5 kg and a
    1863 kg vehicle agree to 0.07 (position) and 0.10 (attitude), measured; with the BlueROV2-sized gains the RexROV
    has not come back after 4 s."""
    bluerov, rexrov = (_recovery(*vehicles[name], {}) for name in ("bluerov2", "rexrov"))
    for a, b in zip(bluerov, rexrov):
        assert np.abs(a - b).max() < 0.15 and a[-1] < 0.02 and b[-1] < 0.02
    position, attitude = _recovery(*vehicles["rexrov"], BLUEROV_SIZED)
    # measured 0.87, 0.90 (0.92, 1.03 before the reference's acceleration was fed forward, issue 48)
    assert np.abs(position - bluerov[0]).max() > 0.5 and attitude[-1] > 0.8


def _station(vehicle, current: float, gains: dict) -> dict:
    """Station keeping, coordinated, for 6 s in a current from ahead [m/s]: the numbers of the report."""
    robot, thrusters, arm = vehicle
    plant = Plant(robot, gravity=True, current=[-current, 0.0, 0.0])
    station = robot.configuration(base=[0.0, 0.0, -5.0, 0.0, 0.0, 0.0], arm=arm)
    actuated = ActuatedPlant(plant, thrusters)
    result = simulate(actuated, station_keeping(actuated, station, DT, ActuatedSettings(**gains)), station, 6.0, DT)
    series, metrics = result.actuation.controller, result.actuation_metrics()
    up = [pin.Quaternion(q[6], q[3], q[4], q[5]).toRotationMatrix()[2, 2] for q in result.q]  # body z . world z
    tilt = float(np.max(np.arccos(np.clip(up, -1.0, 1.0))))
    return {"vehicle": series["vehicle_position_error"].max(), "final": series["vehicle_position_error"][-1],
            "ee": series["ee_point_error"].max(), "tilt": tilt, "thrust_ratio": metrics["max_thrust_ratio"],
            "saturated": metrics["saturated_time_fraction"]}


def test_both_vehicles_hold_station_in_a_current_with_the_default_gains(vehicles):
    """0.3 m/s from ahead. Measured (default gains): BlueROV2 vehicle 4.85 cm, end effector 2.06 cm, tilt 0.020 rad,
    thrust ratio 0.18; RexROV 0.30 cm, 0.14 cm, 0.0009 rad, 0.16 (limits of 1000 N assumed). With the BlueROV2-sized
    gains the RexROV drifts 7.7 cm, tilts 0.034 rad and its end effector is 1.4 cm off (23 cm, 0.096 rad and 13 cm
    before the reference's acceleration was fed forward, issue 48)."""
    bluerov = _station(vehicles["bluerov2"], 0.3, {})
    rexrov = _station(vehicles["rexrov"], 0.3, {})
    assert bluerov["vehicle"] < 0.06 and bluerov["ee"] < 0.025 and bluerov["tilt"] < 0.03, bluerov
    assert rexrov["vehicle"] < 0.01 and rexrov["ee"] < 0.005 and rexrov["tilt"] < 0.005, rexrov
    for numbers in (bluerov, rexrov):
        assert numbers["final"] < 2e-3 and numbers["saturated"] == 0.0 and numbers["thrust_ratio"] < 0.3, numbers
    small = _station(vehicles["rexrov"], 0.3, BLUEROV_SIZED)
    assert small["vehicle"] > 5 * rexrov["vehicle"] and small["tilt"] > 5 * rexrov["tilt"], small
    assert small["ee"] > 1.3 * rexrov["ee"], small  # measured 1.45 (the disturbance observer takes up the rest)


def test_given_gains_win_over_the_derived_ones(vehicles):
    robot, thrusters, arm = vehicles["rexrov"]
    plant = Plant(robot, gravity=True)
    station = robot.configuration(base=[0.0, 0.0, -5.0, 0.0, 0.0, 0.0], arm=arm)
    derived = station_keeping(ActuatedPlant(plant, thrusters), station, DT).velocity
    assert derived.kp is None  # derived where the run starts
    derived.reset(station)
    kp, ki = velocity_gains(vehicle_inertia(plant, station), DEFAULT_BANDWIDTH, DEFAULT_DAMPING_RATIO)
    np.testing.assert_allclose(derived.kp, kp)
    np.testing.assert_allclose(derived.ki, ki)
    assert 50.0 < (derived.kp / np.array(BLUEROV_SIZED["kp"])).min()  # a 1.9 t vehicle: 100 times the BlueROV2's
    given = station_keeping(ActuatedPlant(plant, thrusters), station, DT,
                            ActuatedSettings(kp=BLUEROV_SIZED["kp"], bandwidth=1.0)).velocity
    given.reset(station)
    np.testing.assert_array_equal(given.kp, BLUEROV_SIZED["kp"])  # kp as given, ki from omega = 1 rad/s
    np.testing.assert_allclose(given.ki, velocity_gains(vehicle_inertia(plant, station), 1.0)[1])
