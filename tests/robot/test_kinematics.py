"""The generalized Jacobian (uvms.robot.kinematics): momentum conservation, twist mapping, free-floating dynamics,
one formula for every caller (mass-matrix and centroidal rows), and a clear error on a fixed base."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import uvms
from uvms.dynamics.hydro.hydrodynamics import hydrodynamics_of
from uvms.dynamics.plant.added_mass import augmented_mass_matrix, generalized_jacobian_added_mass, resolve_links
from uvms.errors import ModelCheckError
from uvms.robot import kinematics
from uvms.robot.configuration import Configuration

from conftest import FIXED_ARM, shipped

FREE_FLOATING = ["hoang2011", "santos2006", "xiang2019", "amundsen2018", "bluerov2_alpha5"]
ROWS = {"floating": slice(0, 6), "planar": [0, 1, 5]}


def available(names):
    import uvms

    return [name for name in names if name in uvms.model.shipped_models()]


@pytest.mark.parametrize("name", available(FREE_FLOATING))
def test_momentum_is_zero_and_twist_equals_gjm_times_arm_rates(name, rng):
    robot = shipped(name)
    for _ in range(10):
        q = robot.random_configuration(rng)
        arm_rates = rng.normal(size=robot.n_arm)
        v = robot.free_floating_velocity(q, arm_rates)
        momentum = pin.computeCentroidalMap(robot.model, robot.data, q) @ v
        assert np.max(np.abs(momentum[ROWS[robot.base_type]])) <= 1e-12 * max(1.0, robot.total_mass)
        for frame in robot.ee_frames:
            twist = robot.jacobian(q, frame) @ v
            assert np.allclose(twist, robot.generalized_jacobian(q, frame) @ arm_rates, atol=1e-12, rtol=1e-12)


@pytest.mark.parametrize("name", available(["hoang2011", "amundsen2018"]))
def test_base_velocity_reproduces_a_given_momentum(name, rng):
    robot = shipped(name)
    q = robot.random_configuration(rng)
    rows = ROWS[robot.base_type]
    momentum = rng.normal(size=6)[rows]
    arm_rates = rng.normal(size=robot.n_arm)
    v = robot.free_floating_velocity(q, arm_rates, momentum)
    assert np.allclose((pin.computeCentroidalMap(robot.model, robot.data, q) @ v)[rows], momentum, atol=1e-12)


def rk4_free_floating(robot, q, v, torque, dt):
    """One RK4 step of zero-gravity ABA with the vehicle unactuated, on the manifold."""
    def acceleration(qq, vv):
        tau = np.concatenate([np.zeros(robot.n_vehicle), torque])
        return pin.aba(robot.model, robot.data, qq, vv, tau)

    k1v, k1a = v, acceleration(q, v)
    q2 = pin.integrate(robot.model, q, 0.5 * dt * k1v)
    k2v, k2a = v + 0.5 * dt * k1a, acceleration(q2, v + 0.5 * dt * k1a)
    q3 = pin.integrate(robot.model, q, 0.5 * dt * k2v)
    k3v, k3a = v + 0.5 * dt * k2a, acceleration(q3, v + 0.5 * dt * k2a)
    q4 = pin.integrate(robot.model, q, dt * k3v)
    k4v, k4a = v + dt * k3a, acceleration(q4, v + dt * k3a)
    q_next = pin.integrate(robot.model, q, dt / 6 * (k1v + 2 * k2v + 2 * k3v + k4v))
    return q_next, v + dt / 6 * (k1a + 2 * k2a + 2 * k3a + k4a)


@pytest.mark.parametrize("name", available(["amundsen2018", "hoang2011", "xiang2019"]))
def test_free_floating_dynamics_follow_the_gjm(name, rng):
    """In zero gravity with internal joint torques only, the end effector moves as GJM qdot_m."""
    robot = shipped(name)
    robot_model = robot.model.copy()
    robot_model.gravity = pin.Motion.Zero()
    from uvms import Robot

    plant = Robot(robot_model, ee=robot.ee_frames)
    q = plant.configuration(arm=0.5 * (np.clip(plant.arm_limits[0], -1, 1) + np.clip(plant.arm_limits[1], -1, 1)))
    v = np.zeros(plant.nv)
    torque_amplitude = 0.05 * plant.total_mass
    worst, largest = 0.0, 0.0
    for step in range(400):
        torque = torque_amplitude * np.sin(np.arange(1, plant.n_arm + 1) * 0.02 * step)
        q, v = rk4_free_floating(plant, q, v, torque, dt=1e-3)
        twist = plant.jacobian(q) @ v
        predicted = plant.generalized_jacobian(q) @ v[plant.n_vehicle:]
        worst = max(worst, np.max(np.abs(twist - predicted)))
        largest = max(largest, np.max(np.abs(twist)))
    assert largest > 1e-2  # the end effector really moved
    assert worst <= 1e-7 * largest  # integration error of RK4 at 1 ms


# ------------------------------------------------------------ one formula for every caller
@pytest.mark.parametrize("name", ["amundsen2018", "hoang2011", "bluerov2_alpha5"])
def test_mass_matrix_rows_and_centroidal_rows_give_one_gjm(name, rng):
    """At zero momentum M_bb^-1 M_bm = A_b^-1 A_m (floating and planar): both are the same GJM."""
    robot = shipped(name)
    for _ in range(5):
        q = robot.random_configuration(rng)
        jacobian = robot.jacobian(q)
        mass = pin.crba(robot.model, robot.model.createData(), q)
        mass = np.triu(mass) + np.triu(mass, 1).T
        from_mass = kinematics.generalized_jacobian_from_parts(
            jacobian, *kinematics.mass_matrix_split(mass, robot.n_vehicle), robot.n_vehicle)
        assert np.allclose(from_mass, robot.generalized_jacobian(q), atol=1e-10, rtol=1e-10)


def test_every_caller_keeps_its_numbers_exactly(rng):
    """The callers' own formulas of before, as oracles: bit-identical through the one function."""
    robot = shipped("amundsen2018")
    hydro = hydrodynamics_of(robot)
    links = resolve_links(robot.model, hydro)
    nb = robot.n_vehicle
    for _ in range(5):
        q = robot.random_configuration(rng)
        data = robot.model.createData()
        jacobian = Configuration(robot, q).jacobian(robot.frame_id())  # the one kinematics path
        a_base, a_arm = kinematics.centroidal_map_split(robot.model, data, q, robot.base_type, nb)
        assert np.array_equal(robot.generalized_jacobian(q),
                              jacobian[:, nb:] - jacobian[:, :nb] @ np.linalg.solve(a_base, a_arm))
        mass = augmented_mass_matrix(robot.model, robot.model.createData(), links, q)
        old = jacobian[:, nb:] - jacobian[:, :nb] @ np.linalg.solve(mass[:nb, :nb], mass[:nb, nb:])
        assert np.array_equal(generalized_jacobian_added_mass(robot, hydro, q), old)
        assert np.array_equal(uvms.Plant(robot).generalized_jacobian(q), old)
        held = Configuration(robot, q, momentum=lambda _: kinematics.held_vehicle_split(nb, robot.n_arm))
        assert np.array_equal(held.generalized(held.jacobian(robot.frame_id())), jacobian[:, nb:])
        # computeJointJacobians (the one path) and computeFrameJacobian sum the same terms in another order
        frame_jacobian = pin.computeFrameJacobian(robot.model, data, q, robot.frame_id(), pin.LOCAL_WORLD_ALIGNED)
        assert np.allclose(jacobian, frame_jacobian, rtol=0, atol=1e-13)
        state = Configuration(robot, q)
        assert np.allclose(state.generalized(state.jacobian(robot.frame_id())), robot.generalized_jacobian(q),
                           atol=1e-13)


def test_a_fixed_base_has_no_generalized_jacobian_with_a_clear_error():
    robot = uvms.load(FIXED_ARM)
    state = Configuration(robot, robot.neutral())
    with pytest.raises(ModelCheckError, match="has no vehicle.*floating or planar"):
        state.generalized(state.jacobian(robot.frame_id()))
    with pytest.raises(ModelCheckError, match="has no vehicle"):
        kinematics.centroidal_map_split(robot.model, robot.data, robot.neutral(), robot.base_type, 0)
    with pytest.raises(uvms.UVMSError):  # the solver refuses it too, never a KeyError
        uvms.CLIKSolver(robot, uvms.FrameTask(robot, axes=("x",), target=[0.5, 0, 0, 0, 0, 0]), free_floating=True)
