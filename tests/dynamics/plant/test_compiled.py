"""CompiledPass (uvms.dynamics.plant.compiled): the closures bound once read Pinocchio's numbers of each call's (q, v),
not those of the first."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from uvms.dynamics.plant.plant import Plant

from conftest import shipped


def test_the_bound_inputs_are_pinocchio_s_at_each_call(rng):
    """crba's triangle, rnea's h, data.J and the joints' placements the kernels read are those of the call's (q, v),
    whatever was evaluated before (the arrays are bound once: views of the plant's data)."""
    plant = Plant(shipped("bluerov2_alpha5"), gravity=True)
    compiled = plant._compiled()
    model, data = plant.model, plant.model.createData()  # an independent Data: Pinocchio's own numbers
    for _ in range(4):
        q, v = plant.robot.random_configuration(rng), rng.normal(size=plant.model.nv)
        upper, h, jacobian, placements, accelerations, _, _ = compiled.inputs(q, v, True)
        expected_mass = pin.crba(model, data, q)
        assert np.array_equal(np.triu(upper), np.triu(expected_mass))
        assert np.array_equal(h, pin.rnea(model, data, q, v, np.zeros(model.nv)))
        pin.computeJointJacobians(model, data, q)
        assert np.array_equal(jacobian, data.J)
        last = model.njoints - 1
        assert np.array_equal(placements[last, 9:], data.oMi[last].translation)
        pin.forwardKinematics(model, data, q, v, np.zeros(model.nv))
        assert np.array_equal(accelerations[last], data.a[last].vector)


def test_the_vehicle_wrench_in_one_call_is_the_terms_then_the_wrench_kernel(rng):
    """CompiledPass.vehicle_wrench_into (one compiled call after Pinocchio's) writes the numbers of Mbar and nbar
    (``terms``) followed by the vehicle rows' kernel, bit for bit, for a joint's or a base frame's rate; a later
    ``terms`` at the same (q, v) still gives its Mbar (the call's Mbar and nbar went to the pass's scratch)."""
    from uvms.numerics._kernels.vehicle import vehicle_wrench_into

    plant = Plant(shipped("bluerov2_alpha5"), gravity=True, current=[0.1, 0.0, -0.05])
    compiled = plant._compiled()
    placement = (plant.base_placement.rotation.copy(), plant.base_placement.translation.copy())
    for base_frame in (False, True, False, True):
        q, v = plant.robot.random_configuration(rng), rng.normal(size=plant.model.nv)
        base, arm = rng.normal(size=6), rng.normal(size=plant.model.nv - 6)
        mass, bias = compiled.terms(q, v, None)
        expected = np.empty(6)
        vehicle_wrench_into(mass, bias, base, arm, *placement, base_frame, expected)
        wrench = np.full(6, np.nan)
        compiled.vehicle_wrench_into(q, v, base, arm, placement, base_frame, wrench)
        assert np.array_equal(wrench, expected)
        assert np.array_equal(compiled.terms(q, v, None)[0], mass)


def test_the_observers_call_gives_each_velocitys_numbers_as_evaluated_alone(rng):
    """CompiledPass.vehicle_wrench_into with a second velocity (crba and the Jacobians once, rnea and the kinematics
    at both velocities, one kernel): the wrench at (q, v) is the one without it, Mbar and the nbar at the second
    velocity those of ``terms`` there, bit for bit, for a joint's or a base frame's rate, with a current (the links'
    relative velocity) and without links' motion (the arm at rest); a wrong second velocity (the first's) would give
    the first's nbar: it differs."""
    plant = Plant(shipped("bluerov2_alpha5"), gravity=True, current=[0.2, -0.1, 0.05])
    compiled = plant._compiled()
    placement = (plant.base_placement.rotation.copy(), plant.base_placement.translation.copy())
    nv = plant.model.nv
    for arm_moving, base_frame in ((True, False), (False, True), (True, True)):
        q, v, second = plant.robot.random_configuration(rng), rng.normal(size=nv), rng.normal(size=nv)
        if not arm_moving:
            second[6:] = 0.0
        base, arm = rng.normal(size=6), rng.normal(size=nv - 6)
        expected = np.empty(6)
        compiled.vehicle_wrench_into(q, v, base, arm, placement, base_frame, expected)
        mass, bias = compiled.terms(q, second, None)
        wrench, got_mass, got_bias = np.full(6, np.nan), np.full((nv, nv), np.nan), np.full(nv, np.nan)
        compiled.vehicle_wrench_into(q, v, base, arm, placement, base_frame, wrench, (second, got_mass, got_bias))
        assert np.array_equal(wrench, expected)
        assert np.array_equal(got_mass, mass) and np.array_equal(got_bias, bias)
        assert not np.array_equal(got_bias, compiled.terms(q, v, None)[1])


def test_each_shared_kernel_is_called_with_one_set_of_argument_types(rng):
    """The kinds of call that share a kernel pass it arguments of the same types, so that a run compiles and loads
    one specialization of it: an actuated plant's stage (no torques) and its step's sample (the torques) to
    actuated_rate_into, a passive stage and the plant's dynamics to accelerations_into, the vehicle's inverse
    dynamics with and without a second velocity to vehicle_terms_wrench_into (a second velocity's joints' rows copied
    writable, or typed apart from the Data's read-only views, would make a second one)."""
    import numba

    from uvms.dynamics.plant.actuated import ActuatedPlant, vehicle_inverse_dynamics

    actuated = ActuatedPlant.of(Plant(shipped("bluerov2_alpha5"), gravity=True, current=[0.1, 0.0, -0.05]))
    plant, nv = actuated.plant, actuated.model.nv
    compiled = plant._compiled()
    kernels, typed = compiled.kernels, {}

    class Recording:  # the kernels' module: each call's argument types kept by kernel, then the call
        def __getattr__(self, name):
            def call(*args):
                typed.setdefault(name, set()).add(tuple(numba.typeof(argument) for argument in args))
                return getattr(kernels, name)(*args)
            return call

    compiled.kernels = Recording()
    system = actuated.system(None, dt=0.01)
    q, x = system.initial_state(plant.robot.random_configuration(rng), rng.normal(size=nv))
    sample = system.sample(0.0, q, x)
    system.stage_rate(sample)(0.0, q, x)
    v, arm = x[:nv], rng.normal(size=plant.n_arm)
    plant.dynamics(q, v, arm)
    plant.stage_acceleration(q, v, arm)
    base = rng.normal(size=6)
    vehicle_inverse_dynamics(plant, q, v, base, arm)
    vehicle_inverse_dynamics(plant, q, v, base, arm, second=(rng.normal(size=nv), np.empty((nv, nv)), np.empty(nv)))
    assert sorted(typed) == ["accelerations_into", "actuated_rate_into", "vehicle_terms_wrench_into"]
    assert {name: len(types) for name, types in typed.items()} == dict.fromkeys(typed, 1)
