"""Conventions (uvms.robot.conventions): configuration/base_pose and the Fossen (NED/FRD) accessors."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from uvms.robot import conventions

from conftest import shipped

angles = st.floats(-3.1, 3.1)
positions = st.floats(-50, 50)


@settings(max_examples=60, deadline=None)
@given(st.tuples(positions, positions, positions, angles, st.floats(-1.5, 1.5), angles))
def test_floating_configuration_and_base_pose_round_trip(values):
    robot = shipped("xiang2019")
    q = robot.configuration(base=np.array(values))
    pose = robot.base_pose(q)
    assert np.allclose(pose.translation, values[:3], atol=1e-12)
    assert np.allclose(pose.rotation, pin.rpy.rpyToMatrix(*values[3:]), atol=1e-12)
    assert np.allclose(robot.configuration(base=pose), q, atol=1e-12) or np.allclose(
        robot.configuration(base=pose)[3:7], -q[3:7], atol=1e-12)  # q and -q are one rotation


@settings(max_examples=60, deadline=None)
@given(st.tuples(positions, positions, angles))
def test_planar_configuration_and_base_pose_round_trip(values):
    robot = shipped("hoang2011")
    q = robot.configuration(base=np.array(values))
    pose = robot.base_pose(q)
    assert np.allclose(pose.translation, [values[0], values[1], 0.0], atol=1e-12)
    assert np.arctan2(pose.rotation[1, 0], pose.rotation[0, 0]) == pytest.approx(values[2], abs=1e-12)
    assert np.allclose(robot.configuration(base=pose), q, atol=1e-12)


def test_eta_ned_known_values():
    robot = shipped("xiang2019")
    # ENU position (1, 2, 3), heading east (yaw 0 in ENU) -> NED (2, 1, -3), heading pi/2 (east)
    eta = robot.eta_ned(robot.configuration(base=[1.0, 2.0, 3.0, 0.0, 0.0, 0.0]))
    assert np.allclose(eta, [2.0, 1.0, -3.0, 0.0, 0.0, np.pi / 2], atol=1e-12)
    # nose up 0.2 rad in ENU/FLU (pitch -0.2 about y-left) is pitch +0.2 in NED/FRD
    eta = robot.eta_ned(robot.configuration(base=[0, 0, 0, 0.0, -0.2, np.pi / 2]))
    assert np.allclose(eta[3:], [0.0, 0.2, 0.0], atol=1e-12)
    planar = shipped("hoang2011")
    assert np.allclose(planar.eta_ned(planar.configuration(base=[1.0, 2.0, 0.3])), [2.0, 1.0, np.pi / 2 - 0.3])


def test_nu_frd_known_values():
    robot = shipped("amundsen2018")
    q = robot.random_configuration(0)
    v = np.zeros(robot.nv)
    v[:6] = [1.0, 2.0, 3.0, 0.1, 0.2, 0.3]
    assert np.allclose(robot.nu_frd(q, v), [1.0, -2.0, -3.0, 0.1, -0.2, -0.3])
    planar = shipped("santos2006")
    vp = np.array([1.0, 2.0, 0.3, 0, 0, 0])
    assert np.allclose(planar.nu_frd(planar.neutral(), vp), [1.0, -2.0, -0.3])


@pytest.mark.parametrize("name", ["xiang2019", "hoang2011", "amundsen2018"])
def test_fossen_accessors_round_trip(name, rng):
    robot = shipped(name)
    for _ in range(50):
        q = robot.random_configuration(rng, position_range=20.0)
        eta = robot.eta_ned(q)
        arm = robot.arm_configuration(q)
        q_back = robot.configuration_from_eta(eta, arm)
        assert np.allclose(robot.base_pose(q_back).homogeneous, robot.base_pose(q).homogeneous, atol=1e-12)
        assert np.allclose(robot.arm_configuration(q_back), arm, atol=0)
        v = rng.normal(size=robot.nv)
        nu = robot.nu_frd(q, v)
        assert np.allclose(robot.velocity_from_nu(nu, v[robot.n_vehicle:]), v, atol=1e-15)


def test_nu_is_the_body_velocity_seen_in_ned(rng):
    """The NED-world velocity R_ned_frd @ nu_linear equals d(eta position)/dt."""
    robot = shipped("amundsen2018")
    q = robot.random_configuration(rng)
    v = rng.normal(size=robot.nv)
    dt = 1e-7
    eta_rate = (robot.eta_ned(pin.integrate(robot.model, q, v * dt))
                - robot.eta_ned(pin.integrate(robot.model, q, -v * dt))) / (2 * dt)
    pose = conventions.pose_from_eta(robot.eta_ned(q))
    rotation_ned_frd = conventions.R_NED_ENU @ pose.rotation @ conventions.R_FLU_FRD
    assert np.allclose(rotation_ned_frd @ robot.nu_frd(q, v)[:3], eta_rate[:3], atol=1e-6)
