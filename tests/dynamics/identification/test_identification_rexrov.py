"""Identification of a RexROV-sized vehicle (tests/fixtures/rexrov_like: 1863 kg, uuv_simulator's RexROV added mass
with its couplings, linear and quadratic damping, 8 thrusters of 1000 N): a noise-free excitation written as a bag by
our own writer and read back, then every parameter of the full symmetric added mass, the damping and the buoyancy
recovered within 2 %."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

import uvms
from uvms.dynamics.identification.identify import identify
from uvms.scenario.bags.reader import read_bag
from uvms.scenario.bags.writer import write_bag
from uvms.scenario.excitation import ExcitationControl, excitation_run, multisine

from conftest import ROOT

FIXTURE = ROOT / "tests" / "fixtures" / "rexrov_like" / "rexrov_like.urdf"
#: RMS body wrench [N, N m]: heave strongest (its linear damping, 728 N s/m, hides the quadratic one at low speed);
#: the thrust commands peak at 75 % of the thrusters' 1000 N.
WRENCH = np.array([300.0, 300.0, 1200.0, 80.0, 80.0, 80.0])


def test_a_rexrov_sized_vehicle_gets_every_parameter_within_2_percent(tmp_path):
    robot = uvms.load(str(FIXTURE), ee="tool")
    q0 = pin.neutral(robot.model)
    q0[2] = -20.0
    q0[7:] = [0.0, 0.5, 0.5, 0.0, 0.02]  # the arm forward and down, the gripper half open
    wrench = multisine(WRENCH)
    run, actuated = excitation_run(robot, wrench, q0, 60.0, 0.02)
    # never saturated: the log's wrench is exact
    assert ExcitationControl(actuated, wrench).peak_ratio(60.0, 0.02) < 0.8
    bag = write_bag(tmp_path / "bag", robot, run, thrusters=[f"thruster_{k}" for k in range(8)])
    result = identify(robot, read_bag(bag.path), added_mass="full")
    truth = result.prior.links["base_link"]  # the fixture's hydrodynamics.yaml: the run was simulated with it
    assert all(p.identified for p in result.parameters if p.prior != 0.0)
    added = np.diag(truth.added_mass)
    errors = {}
    for p in result.parameters:
        if p.name.startswith("added_mass[") and "," in p.name:  # a coupling: relative to sqrt(M_ii M_jj)
            i, j = ("uvwpqr".index(axis) for axis in p.name[11:-1].split(","))
            errors[p.name] = abs(p.value - p.prior) / np.sqrt(added[i] * added[j])
        elif p.prior != 0.0:
            errors[p.name] = abs(p.value - p.prior) / abs(p.prior)
        else:  # the centre of buoyancy's x and y (0): the moment within 2 % of its z
            errors[p.name] = abs(p.value) / abs(result.parameter("buoyancy_moment[z]").prior)
    assert len(errors) == 37  # 21 added masses, 6 + 6 dampings, volume, 3 buoyancy moments
    # measured: added-mass diagonal <= 0.08 %, couplings <= 0.04 %, linear damping <= 0.75 %, quadratic <= 1.07 % (w)
    assert max(errors.values()) < 0.02, sorted(errors.items(), key=lambda item: -item[1])[:5]
