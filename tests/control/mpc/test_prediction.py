"""The MPC's prediction model (uvms.control.mpc.prediction): the plant's acceleration under thrusts and arm
commands, and its analytical derivatives against central finite differences (no Crocoddyl needed)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from uvms.control.mpc.prediction import PlantPrediction
from uvms.dynamics.plant.plant import Plant
from uvms.dynamics.thrusters.thrusters import allocation_matrix, thrusters_of

from conftest import shipped

STEP = 1e-6  # central differences: truncation ~ STEP^2, rounding ~ 1e-16 / STEP


def prediction(current=(-0.3, 0.2, 0.1), gravity=True, **options) -> PlantPrediction:
    robot = shipped("bluerov2_alpha5")
    plant = Plant(robot, gravity=gravity, current=np.array(current), **options)
    return PlantPrediction(plant, allocation_matrix(robot, thrusters_of(robot)))


def state(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    robot = shipped("bluerov2_alpha5")
    q = robot.configuration(base=[0.1, 0.2, -5.0, 0.1, -0.2, 0.3], arm=[3.0, 1.8, 1.8, 1.0, 0.005])
    v = rng.normal(size=robot.model.nv) * 0.3
    u = np.concatenate([rng.uniform(-20.0, 20.0, 8), rng.normal(size=5) * 0.2])
    return q, v, u


def central(function, x0: np.ndarray, size: int, move) -> np.ndarray:
    columns = []
    for index in range(size):
        step = np.zeros(size)
        step[index] = STEP
        columns.append((function(move(x0, step)) - function(move(x0, -step))) / (2.0 * STEP))
    return np.array(columns).T


def test_the_acceleration_is_the_plants_under_the_thrusters_wrench(rng):
    model = prediction()
    q, v, u = state(rng)
    expected = model.plant.dynamics(q, v, u[8:], model.matrix @ u[:8])
    dynamics = model.evaluate(q, v, u)
    # the plant's own call: the same bits (acceleration, motor torques, Mbar)
    np.testing.assert_array_equal(dynamics.acceleration, expected.acceleration)
    np.testing.assert_array_equal(dynamics.joint_torque, expected.joint_torque)
    np.testing.assert_array_equal(dynamics.mass_matrix, expected.mass_matrix)
    assert np.abs(model.acceleration(q, v, u) - model.plant.dynamics(q, v, u[8:]).acceleration).max() > 0.1


def test_the_inverse_dynamics_with_the_links_wrenches_balances_the_thrusters(rng):
    """rnea with the hydrodynamic wrenches as fext at the plant's acceleration: the vehicle rows are the thrusters'
    generalized force and the arm rows the motors' torques (the wrenches summed as the plant sums them)."""
    model = prediction()
    q, v, u = state(rng)
    dynamics = model.evaluate(q, v, u)
    torque, _, _ = model.inverse_dynamics_derivatives(q, v, dynamics.acceleration)
    np.testing.assert_allclose(torque[:6], model.thrust_map[:6] @ u[:8], atol=1e-9)
    np.testing.assert_allclose(torque[6:], dynamics.joint_torque, atol=1e-9)


@pytest.mark.parametrize("options", [
    {},  # current, buoyancy, added mass and damping
    {"current": (0.0, 0.0, 0.0), "gravity": False},
    {"added_mass": False},
    {"damping": False},
], ids=["all", "still-weightless", "no-added-mass", "no-damping"])
def test_the_analytical_derivatives_match_central_differences(rng, options):
    model = prediction(**options)
    q, v, u = state(rng)
    dynamics = model.evaluate(q, v, u)
    da_dq, da_dv, da_du = model.derivatives(q, v, u, dynamics.acceleration, dynamics.mass_matrix)
    pinocchio_model = model.model
    numeric = (central(lambda x: model.acceleration(x, v, u), q, model.nv,
                       lambda x, d: pin.integrate(pinocchio_model, x, d)),
               central(lambda x: model.acceleration(q, x, u), v, model.nv, lambda x, d: x + d),
               central(lambda x: model.acceleration(q, v, x), u, model.nu, lambda x, d: x + d))
    for analytical, finite in zip((da_dq, da_dv, da_du), numeric):
        assert np.abs(finite).max() > 1.0  # not a comparison of zeros
        np.testing.assert_allclose(analytical, finite, rtol=0, atol=1e-6)


def test_a_constant_disturbance_on_the_vehicle_adds_to_the_thrusters_and_changes_no_derivative(rng):
    model = prediction()
    q, v, u = state(rng)
    model.disturbance = np.array([5.0, -3.0, 2.0, 0.5, -0.4, 0.3])
    thrusts = np.linalg.lstsq(model.matrix, model.disturbance, rcond=None)[0]
    shifted = u.copy()
    shifted[:8] += thrusts
    model_without = prediction()
    np.testing.assert_allclose(model.acceleration(q, v, u), model_without.acceleration(q, v, shifted), atol=1e-9)
    dynamics = model.evaluate(q, v, u)
    da_dq, _, _ = model.derivatives(q, v, u, dynamics.acceleration, dynamics.mass_matrix)
    numeric = central(lambda x: model.acceleration(x, v, u), q, model.nv,
                      lambda x, d: pin.integrate(model.model, x, d))
    np.testing.assert_allclose(da_dq, numeric, rtol=0, atol=1e-6)
    generalized = model.thrust_map[:6] @ thrusts
    np.testing.assert_allclose(model.wrench_of(generalized), model.disturbance, atol=1e-9)


def test_the_mpc_reads_only_the_plants_public_surface():
    """No module of uvms.control.mpc reads a private member of the plant (its accessors: dynamics, base_frame,
    stacked_links, current, buoyant)."""
    import ast
    from pathlib import Path

    import uvms.control.mpc as package

    private = []
    for path in Path(package.__file__).parent.glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Attribute) and node.attr.startswith("_") and not node.attr.startswith("__"):
                owner = ast.unparse(node.value)
                if owner.split(".")[-1] in ("plant", "the_plant"):
                    private.append(f"{path.name}: {owner}.{node.attr}")
    assert private == []


def test_the_plants_accessors_are_what_it_computes_with(rng):
    model = prediction()
    plant = model.plant
    assert plant.model.frames[plant.base_frame].name == plant.robot.root_link
    np.testing.assert_allclose(plant.current, [-0.3, 0.2, 0.1])
    plant.current[0] = 5.0  # a copy: the plant's current is not changed through it
    np.testing.assert_allclose(plant.current, [-0.3, 0.2, 0.1])
    assert plant.buoyant and plant.stacked_links.count == len(plant.links)
    q, v, u = state(rng)
    np.testing.assert_allclose(plant.dynamics(q, v, u[8:]).acceleration, plant.acceleration(q, v, u[8:]), atol=1e-12)


def test_the_derivatives_are_written_into_the_given_arrays(rng):
    """The action model hands Crocoddyl's arrays to the prediction (no copies): the same numbers as new arrays."""
    model = prediction()
    q, v, u = state(rng)
    dynamics = model.evaluate(q, v, u)
    fresh = model.derivatives(q, v, u, dynamics.acceleration, dynamics.mass_matrix)
    given = np.full((model.nv, model.nv), np.nan), np.full((model.nv, model.nv), np.nan), np.full((model.nv, model.nu),
                                                                                                    np.nan)
    returned = model.derivatives(q, v, u, dynamics.acceleration, dynamics.mass_matrix, out=given)
    for into, expected, back in zip(given, fresh, returned):
        assert back is into
        np.testing.assert_allclose(into, expected, rtol=0, atol=1e-12)
