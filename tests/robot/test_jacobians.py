"""World-aligned Jacobians (uvms.robot.robot) against finite differences of the forward kinematics."""

from __future__ import annotations

import numpy as np
import pytest

import uvms

from conftest import ROOT, SHIPPED, finite_difference_jacobian, shipped


def composed_robot() -> uvms.Robot:
    return uvms.model.mount_arm(shipped("santos2006"), "z1", placement=[2.5, 0.0, -0.5, np.pi, 0.0, 0.0])


@pytest.mark.parametrize("name", SHIPPED)
def test_jacobian_matches_finite_differences(name, rng):
    robot = shipped(name)
    for _ in range(5):
        q = robot.random_configuration(rng)
        for frame in robot.ee_frames:
            jacobian = robot.jacobian(q, frame)
            assert jacobian.shape == (6, robot.nv)
            assert np.max(np.abs(jacobian - finite_difference_jacobian(robot, q, frame))) <= 1e-6


def test_composed_model_jacobian_matches_finite_differences(rng):
    robot = composed_robot()
    for _ in range(3):
        q = robot.random_configuration(rng)
        for frame in robot.ee_frames:
            assert np.max(np.abs(robot.jacobian(q, frame) - finite_difference_jacobian(robot, q, frame))) <= 1e-6


def test_fixed_base_option_drops_the_vehicle(rng):
    robot = uvms.load(ROOT / "models" / "hoang2011" / "uvms.urdf.xacro")
    arm_only = uvms.load(uvms.model.example_robot_urdf("ur5"))
    assert arm_only.base_type == "fixed" and arm_only.n_vehicle == 0
    floating_ur5 = uvms.load(uvms.model.example_robot_urdf("ur5"), base="floating")
    assert floating_ur5.n_vehicle == 6 and floating_ur5.nv == arm_only.nv + 6
    q = floating_ur5.random_configuration(rng)
    frame = floating_ur5.ee_frames[0]
    assert np.max(np.abs(floating_ur5.jacobian(q, frame) - finite_difference_jacobian(floating_ur5, q, frame))) <= 1e-6
    assert robot.n_vehicle == 3


def test_manipulability_is_product_of_singular_values(rng):
    robot = shipped("hoang2011")
    q = robot.random_configuration(rng)
    jacobian = robot.jacobian(q)[[0, 1, 5]]
    assert robot.manipulability(q) == pytest.approx(np.sqrt(np.linalg.det(jacobian @ jacobian.T)), rel=1e-10)
    generalized = robot.generalized_jacobian(q)[[0, 1, 5]]
    assert robot.generalized_manipulability(q) == pytest.approx(abs(np.linalg.det(generalized)), rel=1e-10)
    # stretched arm (q2 = q3 = 0): the arm alone is singular in the plane only when fully aligned
    stretched = robot.configuration(arm=[1.0, 0.0, 0.0])
    bent = robot.configuration(arm=[1.0, 1.0, 1.0])
    assert robot.generalized_manipulability(stretched) < robot.generalized_manipulability(bent)
