"""Every joint's placement and motion of a pin.Data as arrays (uvms.dynamics.plant.data_views): views of
Pinocchio's memory that show what its algorithms wrote, the same numbers as its getters and as the owned buffers."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from test_plant_mimic import MIMIC_URDF

import uvms
from uvms.dynamics.plant.data_views import JointArrays
from uvms.dynamics.plant.plant import Plant

from conftest import shipped


def getters(data: pin.Data) -> tuple[np.ndarray, np.ndarray]:
    """The rows JointArrays promises, read joint by joint through Pinocchio's getters."""
    placements = np.array([np.concatenate([m.rotation.ravel(order="F"), m.translation]) for m in data.oMi])
    return placements, np.array([m.vector for m in data.a])


@pytest.mark.parametrize("source", ["mimic", "bluerov2_alpha5"])
def test_the_joint_arrays_are_views_that_follow_the_data(source, rng):
    robot = uvms.load(MIMIC_URDF) if source == "mimic" else shipped(source)
    model = robot.model
    data = model.createData()
    viewed, owned = JointArrays(data), JointArrays(data, view=False)
    assert viewed.viewed and not owned.viewed
    placements, motions = viewed.read()
    assert placements.shape == (model.njoints, 12) and motions.shape == (model.njoints, 6)
    assert not placements.flags.writeable and not motions.flags.writeable  # Pinocchio's memory: never written here
    for _ in range(3):
        q = pin.integrate(model, robot.neutral(), rng.normal(size=model.nv))
        pin.forwardKinematics(model, data, q, rng.normal(size=model.nv), rng.normal(size=model.nv))
        expected = getters(data)
        assert np.abs(expected[0][1:, 9:]).max() > 0.01 and np.abs(expected[1][1:]).max() > 0.1  # moved
        for arrays in (viewed.read(), owned.read()):
            np.testing.assert_array_equal(arrays[0], expected[0])
            np.testing.assert_array_equal(arrays[1], expected[1])
        assert viewed.read()[0] is placements  # the same views, not copies per read


def test_the_plants_terms_are_the_same_through_views_and_through_the_getters(rng):
    """The plant's Mbar and nbar with the joint arrays read as views equal those read through the getters, bit for
    bit (a current, gravity and a body wrench: every term reads the placements or the bias accelerations)."""
    robot = shipped("bluerov2_alpha5")
    plant = Plant(robot, gravity=True, current=[0.3, -0.2, 0.1])
    for _ in range(3):
        q = pin.integrate(robot.model, robot.neutral(), rng.normal(size=robot.nv))
        v, wrench = rng.normal(size=robot.nv), rng.normal(size=6) * 20.0
        plant._joint_arrays = JointArrays(plant.data)
        viewed = plant._mass_and_bias(q, v, wrench)
        plant._joint_arrays = JointArrays(plant.data, view=False)
        owned = plant._mass_and_bias(q, v, wrench)
        np.testing.assert_array_equal(viewed[0], owned[0])
        np.testing.assert_array_equal(viewed[1], owned[1])


def test_a_copy_views_its_own_copy_of_the_data(rng):
    """Copied or pickled with its Data, JointArrays views the copy's memory (never a stale copy of the numbers)."""
    import copy
    import pickle

    robot = shipped("bluerov2_alpha5")
    model = robot.model
    data = model.createData()
    for make in (copy.deepcopy, lambda pair: pickle.loads(pickle.dumps(pair))):
        copied_data, copied = make((data, JointArrays(data)))
        assert copied.viewed and copied_data is not data
        pin.forwardKinematics(model, copied_data, pin.integrate(model, robot.neutral(), rng.normal(size=model.nv)),
                              rng.normal(size=model.nv), rng.normal(size=model.nv))
        expected = getters(copied_data)
        np.testing.assert_array_equal(copied.read()[0], expected[0])
        np.testing.assert_array_equal(copied.read()[1], expected[1])


def test_a_view_keeps_its_data_alive(rng):
    """The arrays outlive every other reference to the Data and the JointArrays: they still read its numbers (the
    Data is not freed under them)."""
    import gc

    robot = shipped("bluerov2_alpha5")
    model = robot.model
    data = model.createData()
    q = pin.integrate(model, robot.neutral(), rng.normal(size=model.nv))
    pin.forwardKinematics(model, data, q, rng.normal(size=model.nv), rng.normal(size=model.nv))
    expected = getters(data)
    placements, motions = JointArrays(data).read()
    del data
    gc.collect()
    for _ in range(50):  # memory freed and reused would show other numbers here
        model.createData()
    np.testing.assert_array_equal(placements, expected[0])
    np.testing.assert_array_equal(motions, expected[1])
