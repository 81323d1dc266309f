"""The plant series derived from the stored states (issue 46): computed after the loop, when first read."""

import numpy as np
import pytest

import uvms
from uvms.control import OpenLoop
from uvms.sim import simulate
from uvms.sim.series import PlantSeries


def test_the_energies_and_momentum_are_derived_once_from_the_stored_states():
    """A plant run records no energy inside its loop; read, the series equal the plant's energy and momentum of each
    stored state (the numbers the loop recorded per row before), and the derivation runs once."""
    robot = uvms.load("bluerov2_alpha5")
    plant = uvms.Plant(robot, gravity=True, current=[0.2, 0.0, 0.0])
    q0 = robot.configuration(base=[0.0, 0.0, -5.0, 0.0, 0.0, 0.0], arm=[3.0, 1.8, 1.8, 1.0, 0.0])
    result = simulate(plant, OpenLoop(arm=np.full(plant.n_arm, 0.2)), q0, 0.1, 0.01)
    series = result.plant
    assert "kinetic_energy" not in vars(series)  # not computed by the loop
    expected = [plant.energy(q, v) for q, v in zip(result.q, result.v)]
    np.testing.assert_array_equal(series.kinetic_energy, [kinetic for kinetic, _ in expected])
    np.testing.assert_array_equal(series.potential_energy, [potential for _, potential in expected])
    np.testing.assert_array_equal(series.momentum[7], plant.momentum(result.q[7], result.v[7]))
    assert np.ptp(series.kinetic_energy) > 1e-3  # the arm moves: the energy changes


def test_given_series_are_kept_and_missing_ones_refused():
    """Series given are kept as they are; without them and without derive the series cannot be made."""
    n = 3
    given = PlantSeries(np.zeros((n, 2)), np.ones((n, 2)), np.arange(3.0), np.zeros(n), np.zeros((n, 6)))
    np.testing.assert_array_equal(given.energy, [0.0, 1.0, 2.0])
    calls = []
    lazy = PlantSeries(np.zeros((n, 2)), np.ones((n, 2)),
                       derive=lambda: calls.append(1) or {"kinetic_energy": np.ones(n), "potential_energy": np.ones(n),
                                                          "momentum": np.ones((n, 6))})
    assert calls == [] and lazy.energy.tolist() == [2.0, 2.0, 2.0] and lazy.momentum.shape == (n, 6)
    assert calls == [1]
    with pytest.raises(ValueError, match="derive"):
        PlantSeries(np.zeros((n, 2)), np.ones((n, 2)))
