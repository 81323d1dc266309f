"""One integrator, one generalized-Jacobian formula, one loop: the restructured core keeps every number."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import uvms
from conftest import shipped
from uvms.robot import kinematics
from uvms.dynamics.hydrodynamics import hydrodynamics_of
from uvms.dynamics.added_mass import augmented_mass_matrix, generalized_jacobian_added_mass, resolve_links
from uvms.errors import ModelCheckError
from uvms.numerics.integrate import INTEGRATORS, STEPS, check_integrator
from uvms.numerics.inverses import damped_weighted_inverse
from uvms.robot.configuration import Configuration

FIXED_ARM = """<robot name="arm"><link name="base"/><link name="tip"><inertial><mass value="1"/>
  <inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="tip"/><axis xyz="0 0 1"/>
  <limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>"""


# ------------------------------------------------------------ the GJM formula
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
        jacobian = pin.computeFrameJacobian(robot.model, data, q, robot.frame_id(), pin.LOCAL_WORLD_ALIGNED)
        a_base, a_arm = kinematics.centroidal_map_split(robot.model, data, q, robot.base_type, nb)
        assert np.array_equal(robot.generalized_jacobian(q), jacobian[:, nb:] - jacobian[:, :nb] @ np.linalg.solve(a_base, a_arm))
        mass = augmented_mass_matrix(robot.model, robot.model.createData(), links, q)
        old = jacobian[:, nb:] - jacobian[:, :nb] @ np.linalg.solve(mass[:nb, :nb], mass[:nb, nb:])
        assert np.array_equal(generalized_jacobian_added_mass(robot, hydro, q), old)
        assert np.array_equal(uvms.Plant(robot).generalized_jacobian(q), old)
        held = Configuration(robot, q, momentum=lambda _: kinematics.held_vehicle_split(nb, robot.n_arm))
        # computeJointJacobians and computeFrameJacobian sum the same terms in another order: rounding apart
        assert np.allclose(held.generalized(held.jacobian(robot.frame_id())), jacobian[:, nb:], rtol=0, atol=1e-13)
        state = Configuration(robot, q)
        assert np.allclose(state.generalized(state.jacobian(robot.frame_id())), robot.generalized_jacobian(q), atol=1e-13)


def test_a_fixed_base_has_no_generalized_jacobian_with_a_clear_error():
    robot = uvms.load(FIXED_ARM)
    state = Configuration(robot, robot.neutral())
    with pytest.raises(ModelCheckError, match="has no vehicle.*floating or planar"):
        state.generalized(state.jacobian(robot.frame_id()))
    with pytest.raises(ModelCheckError, match="has no vehicle"):
        kinematics.centroidal_map_split(robot.model, robot.data, robot.neutral(), robot.base_type, 0)
    with pytest.raises(uvms.UVMSError):  # the solver refuses it too, never a KeyError
        uvms.CLIKSolver(robot, uvms.FrameTask(robot, axes=("x",), target=[0.5, 0, 0, 0, 0, 0]), free_floating=True)


# ------------------------------------------------------------ the integrator
def test_one_step_per_scheme_serves_q_alone_and_q_with_x_exactly_on_the_manifold():
    """A rigid body spinning about a fixed axis: q alone (kinematic), then (q, v) with v' = 0 (dynamic)."""
    model = uvms.load(FIXED_ARM, base="floating").model  # a free vehicle (nq = 7 + 1): spin it, arm at rest
    twist = np.concatenate([[0.2, -0.1, 0.3, 0.5, -0.4, 0.7], [0.0]])
    exact = pin.integrate(model, pin.neutral(model), twist * 1.0)
    empty = np.zeros(0)
    for name in INTEGRATORS:
        errors = []
        for steps in (10, 20):
            dt, q, v = 1.0 / steps, pin.neutral(model), twist.copy()
            for k in range(steps):
                q, v = STEPS[name](model, lambda t, qq, vv: (vv, np.zeros(7)), k * dt, q, v, dt, (v, np.zeros(7)))
            q_alone = pin.neutral(model)
            for k in range(steps):
                q_alone, _ = STEPS[name](model, lambda t, qq, x: (twist, empty), k * dt, q_alone, empty, dt, (twist, empty))
            assert np.array_equal(q, q_alone)
            errors.append(np.linalg.norm(pin.difference(model, q, exact)))
        assert errors[1] <= 1e-12  # a constant body twist is the exponential map: exact for both
    with pytest.raises(uvms.UVMSError, match="unknown method 'rk45'; valid: euler, rk4"):
        check_integrator("rk45", "method")


# ------------------------------------------------------------ GJM control is the CLIK of the core
def old_gjm_rates(robot, jacobian6, generalized6, reference_sample, pose, rows, gain, damping):
    """The law GJMController computed with its own code before (eq. 4-8), as an oracle."""
    error = reference_sample.pose.translation - pose.translation
    command = reference_sample.twist.copy()
    command[:3] += gain * np.eye(3) @ error
    inverse, _, _ = damped_weighted_inverse(generalized6[rows], None, damping)
    return inverse @ command[rows]


@pytest.mark.parametrize("name, axes", [("amundsen2018", ("x", "y", "z")), ("hoang2011", ("x", "y")),
                                        ("amundsen2018", ("x", "y", "z", "yaw"))])
def test_the_gjm_controller_keeps_the_numbers_of_its_own_law(name, axes, rng):
    from uvms.control.gjm import GJMController, VelocityRamps

    robot = shipped(name)
    q = robot.random_configuration(rng)
    reference = VelocityRamps.trapezoid(robot.fk(q).translation + 0.01, [-0.05, -0.05, 0.05], 8.0, 1.0)
    rows = kinematics.axis_rows(axes)
    data = robot.model.createData()
    jacobian = pin.computeFrameJacobian(robot.model, data, q, robot.frame_id(), pin.LOCAL_WORLD_ALIGNED)
    pose = data.oMf[robot.frame_id()]
    for gain, damping in ((0.0, 0.0), (3.0, uvms.solvers.VariableDamping(0.5, 0.2))):
        controller = GJMController(robot, reference, axes=axes, gain=gain, damping=damping)
        expected = old_gjm_rates(robot, jacobian, robot.generalized_jacobian(q), reference(3.0), pose, rows, gain, damping)
        # the controller's Configuration computes all joint Jacobians (computeJointJacobians) where the old law
        # called computeFrameJacobian: the same terms summed in another order, rounding apart
        assert np.allclose(controller.sample(q, 3.0).rates, expected, rtol=1e-12, atol=1e-14)
        task = uvms.FrameTask(robot, axes=axes, orientation="log", target=reference(3.0).pose)
        task.set_target_velocity(reference(3.0).twist)
        gains = np.array([gain if row < 3 else 0.0 for row in rows])
        clik = uvms.CLIKSolver(robot, task, gain=gains, damping=damping, free_floating=True).velocity(Configuration(robot, q))
        assert np.allclose(clik.v[robot.n_vehicle:], expected, atol=1e-12)  # the same law through CLIKSolver


def test_one_result_type_and_no_old_paths():
    """One simulate, one result type; the module paths and names of before the layer folders are gone (no shims)."""
    import importlib

    from uvms.control import gjm
    from uvms.dynamics import plant
    from uvms.sim.result import SimulationResult

    robot = shipped("hoang2011")
    result = uvms.simulate(uvms.Plant(robot), np.ones(robot.n_arm), robot.neutral(), 0.1, 0.01)
    assert isinstance(result, SimulationResult) and result.plant.command.shape == (11, robot.n_arm)
    assert result.ee_position is None and result.arrays().keys() == {"t", "q", "v"}
    assert result.tracking is None and result.actuation is None
    assert result.integrator == "rk4" and not hasattr(result, "method")
    for module, name in ((plant, "simulate_plant"), (plant, "PlantResult"), (gjm, "simulate_gjm"), (gjm, "GJMResult"),
                         (uvms, "PlantResult"), (uvms, "GJMResult"), (uvms, "simulate_plant"), (uvms, "simulate_gjm"),
                         (uvms, "simulate_actuated"), (uvms, "actuation_metrics")):
        assert not hasattr(module, name), f"{module.__name__}.{name}"
    for old in ("uvms.plant", "uvms.plotting", "uvms.sandbox", "uvms.sweep", "uvms.moved", "uvms.sim.actuated",
                "uvms.sim.simulate", "uvms.control.station_keeping"):
        with pytest.raises(ModuleNotFoundError):
            importlib.import_module(old)
    with pytest.raises(TypeError):  # integrator is the one name of the choice
        uvms.simulate(uvms.Plant(robot), None, robot.neutral(), 0.1, 0.01, method="euler")
