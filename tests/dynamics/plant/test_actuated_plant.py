"""ActuatedPlant.of (uvms.dynamics.plant.actuated): a plant with its model's thrusters and fins."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import uvms
from uvms.dynamics.hydro.hydrodynamics import hydrodynamics_of
from uvms.dynamics.plant.actuated import ActuatedPlant
from uvms.dynamics.plant.plant import Plant
from uvms.dynamics.thrusters.fins import fins_of
from uvms.dynamics.thrusters.thrusters import allocation_matrix, thrusters_of
from uvms.errors import BaseGuessWarning, PointMassWarning, UVMSError

from conftest import body_urdf, shipped

TORPEDO = Path(__file__).parents[2] / "fixtures" / "auv" / "torpedo.urdf"


def test_of_puts_the_models_thrusters_on_the_plant_at_rest():
    blue = shipped("bluerov2_alpha5")
    plant = Plant(blue)
    actuated = ActuatedPlant.of(plant)
    thrusters = thrusters_of(blue)
    assert actuated.plant is plant and actuated.thrusters.names == thrusters.names and actuated.n == 8
    np.testing.assert_allclose(actuated.matrix, allocation_matrix(blue, thrusters), atol=1e-15)
    np.testing.assert_array_equal(actuated.thrusts0, np.zeros(8))
    assert actuated.m == 0 and ActuatedPlant.of(plant, fins=False).m == 0  # the BlueROV2 has no fins


def test_of_refuses_a_model_without_thrusters():
    with pytest.raises(UVMSError, match="no thrusters"):
        ActuatedPlant.of(Plant(uvms.load(body_urdf())))


def test_of_gives_the_fins_when_asked():
    with pytest.warns(PointMassWarning), pytest.warns(BaseGuessWarning):
        torpedo = uvms.load(TORPEDO)
    plant = Plant(torpedo, hydrodynamics_of(torpedo))
    assert ActuatedPlant.of(plant).fins.names == fins_of(torpedo).names and ActuatedPlant.of(plant).m == 4
    assert ActuatedPlant.of(plant, fins=False).m == 0 and ActuatedPlant.of(plant, fins=False).n == 1
