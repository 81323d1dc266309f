"""The plant's compiled pass (uvms.numerics._kernels.hydro): the links' LOCAL Jacobians formed from Pinocchio's world
Jacobian are ``pin.getFrameJacobian``'s, a mimic joint's column folded into its driver's."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import uvms
from uvms.numerics._kernels.hydro import frame_jacobian_into, frame_jacobian_program

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "dynamics" / "plant"))
from test_plant_mimic import MIMIC_URDF  # noqa: E402

from conftest import shipped  # noqa: E402


@pytest.mark.parametrize("source", ["mimic", "bluerov2_alpha5"])
def test_the_frame_jacobians_from_the_world_jacobian_are_pinocchios(source, rng):
    robot = uvms.load(MIMIC_URDF) if source == "mimic" else shipped(source)
    model = robot.model
    data = model.createData()
    frames = [frame for frame in range(model.nframes) if model.frames[frame].type == pin.FrameType.BODY]
    for _ in range(5):
        q = pin.integrate(model, robot.neutral(), rng.normal(size=model.nv))
        pin.computeJointJacobians(model, data, q)
        for frame_id in frames:
            frame = model.frames[frame_id]
            out, rotation = np.full((6, model.nv), np.nan), np.full((3, 3), np.nan)
            frame_jacobian_into(data.J, data.oMi[frame.parentJoint].homogeneous, frame.placement.rotation.copy(),
                                frame.placement.translation.copy(),
                                frame_jacobian_program(model, data, frame.parentJoint), out, rotation)
            expected = pin.getFrameJacobian(model, data, frame_id, pin.LOCAL)
            np.testing.assert_array_equal(out, expected)  # its operations in its order: the same bits
            np.testing.assert_allclose(rotation, (data.oMi[frame.parentJoint] * frame.placement).rotation, atol=1e-15)
            if frame.name == "link_b":  # on the mimic finger: it moves with its driver's coordinate (finger_a)
                assert np.abs(out[:, model.idx_vs[model.getJointId("finger_a")]]).max() > 0.1


def in_order(terms) -> float:
    """The terms' sum from 0.0, left to right (Python's ``sum`` of floats compensates from 3.12 on)."""
    total = 0.0
    for term in terms:
        total += term
    return total


def test_the_added_mass_matrix_is_summed_in_the_kernels_order(rng):
    """Mbar = M + sum_l J_l^T (M_A,l J_l) over the columns J_l moves, each entry's sums from 0.0 in index order: the
    compiled pass's numbers, bit for bit, against that arithmetic written out in Python over getFrameJacobian's J_l
    (numpy's J^T M_A J, through BLAS, is not these bits)."""
    from uvms.dynamics.plant.plant import Plant

    plant = Plant(shipped("bluerov2_alpha5"), gravity=True, current=[0.3, -0.2, 0.1])
    model, nv = plant.model, plant.model.nv
    data = model.createData()
    blas_differs = 0
    for _ in range(3):
        q = pin.integrate(model, plant.robot.neutral(), rng.normal(size=nv))
        upper = pin.crba(model, model.createData(), q)
        expected = np.triu(upper) + np.triu(upper, 1).T
        blas = expected.copy()
        pin.computeJointJacobians(model, data, q)
        for link, inertia in zip(plant.links, plant.stacked_links.added_mass):
            jacobian = pin.getFrameJacobian(model, data, link.frame_id, pin.LOCAL)
            moved = [column for column in range(nv) if np.any(jacobian[:, column] != 0.0)]
            product = {column: [in_order(inertia[i, k] * jacobian[k, column] for k in range(6)) for i in range(6)]
                       for column in moved}
            for row in moved:
                for column in moved:
                    expected[row, column] += in_order(jacobian[i, row] * product[column][i] for i in range(6))
            blas += jacobian.T @ inertia @ jacobian
        mass, _ = plant._mass_and_bias(q, rng.normal(size=nv))
        np.testing.assert_array_equal(mass, expected)
        blas_differs += not np.array_equal(mass, blas)
    assert blas_differs
