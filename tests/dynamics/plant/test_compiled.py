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
