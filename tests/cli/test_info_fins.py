"""`uvms info` of AUVs with fins: the fin joints as control surfaces with their reason, each fin's plugin data, and an
allocation line that says what the propeller gives at rest and what the fins add with speed."""

from __future__ import annotations

from uvms.cli import main

from conftest import ROOT

AUV = ROOT / "tests" / "fixtures" / "auv"


def test_info_lists_the_torpedo_fins_and_what_they_add_at_speed(capsys):
    """Before: "the mass matrix is singular ... point-mass link(s) torpedo/fin0" (the fins were arm joints)."""
    assert main(["info", str(AUV / "torpedo.urdf")]) == 0
    out = capsys.readouterr().out
    assert "base        floating: vehicle DOF 6, arm DOF 0" in out
    assert ("fins (4): control surfaces turned by a fin plugin; frozen in the kinematics, their angle an actuator of "
            "the actuated plant (lift and drag with the vehicle's speed)\n"
            "  torpedo/fin0_joint       uuv_simulator fin plugin 'torpedo_fin0_model' names it (<joint_name>); held "
            "at 0\n") in out
    assert ("  torpedo_fin1_model  torpedo/fin1_joint  xyz [-0.75  0.    0.12]  [-0.4, 0.4]  0.2  uuv Quadratic lift "
            "20 drag 9\n") in out
    line = next(line for line in out.splitlines() if line.startswith("allocation  "))
    assert line.startswith("allocation  at rest the thrusters produce 1 of the 6 body-wrench directions; missing: a y "
                           "force, a z force, a roll moment, a pitch moment, a yaw moment")
    assert "at 1 m/s forward through the water the 4 fins' lift adds 3 directions" in line
    assert "the thrusters and fins produce 4 of the 6 body-wrench directions; missing: a pitch moment, a yaw " in line


def test_info_lists_gazebo_sim_lift_drag_fins_and_their_defaults(capsys):
    assert main(["info", str(AUV / "gz_lrauv" / "lrauv_like.urdf")]) == 0
    captured = capsys.readouterr()
    assert ("  vertical_fins_joint      Gazebo Sim LiftDrag 'gz::sim::systems::LiftDrag' names it "
            "(<control_joint_name>); held at 0\n") in captured.out
    assert ("  horizontal_fins  horizontal_fins_joint  xyz [-0.6  0.   0. ]  [-0.26, 0.26]  0.1  gz LiftDrag cla 4.13 "
            "cda 0.2 stall 0.17 rad, area 0.0244 m^2, rho 1000 (no ocean current: gz subtracts a wind only)\n"
            ) in captured.out
    assert ("  base_link  no joint: a fixed lifting surface  xyz [0. 0. 0.]  fixed (no angle)  "
            "gz LiftDrag") in captured.out
    assert "  note: " in captured.out and "horizontal_fins, vertical_fins take uvms's default time constant 0.1 s" \
        in captured.out
