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
            np.testing.assert_allclose(out, expected, rtol=0.0, atol=1e-14)
            np.testing.assert_allclose(rotation, (data.oMi[frame.parentJoint] * frame.placement).rotation, atol=1e-15)
            if frame.name == "link_b":  # on the mimic finger: it moves with its driver's coordinate (finger_a)
                assert np.abs(out[:, model.idx_vs[model.getJointId("finger_a")]]).max() > 0.1
