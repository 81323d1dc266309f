"""The compiled square solve (uvms.numerics._kernels.solve): numpy.linalg.solve's numbers bit for bit, from any layout
of A, through the LAPACK numpy calls, or scipy.linalg.lapack.dgesv's (the RK4 stages' tangent solve) through SciPy's;
a singular or non-finite system refused, and a plant's vehicle block with it."""

from __future__ import annotations

import llvmlite.binding as llvm
import numpy as np
import pytest
from scipy.linalg import lapack

from uvms.dynamics.plant.plant import Plant
from uvms.errors import NumericalError
from uvms.numerics._kernels.solve import (
    NUMPY_SYMBOL,
    SCIPY_SYMBOL,
    dgesv_into,
    numpy_dgesv_address,
    scipy_dgesv_address,
    solve_into,
)

from conftest import shipped


@pytest.mark.parametrize("size", [1, 2, 3, 6, 11])
def test_the_compiled_solve_gives_numpys_numbers_from_any_layout(size):
    rng = np.random.default_rng(size)
    for _ in range(200):
        whole = rng.normal(size=(size + 2, size + 3))
        matrix = whole[1:size + 1, 2:size + 2]  # a strided view, as a plant's block Mbar[:nb, :nb]
        rhs, out = rng.normal(size=size), np.empty(size)
        expected = np.linalg.solve(matrix, rhs)
        for layout in (matrix, np.ascontiguousarray(matrix), np.asfortranarray(matrix)):
            assert solve_into(layout, rhs, out)
            assert out.tobytes() == expected.tobytes()


def test_the_compiled_solve_with_scipys_lapack_gives_scipys_dgesv_numbers():
    rng = np.random.default_rng(5)
    for size in (3, 6, 11):
        for _ in range(200):
            matrix = np.eye(size)  # dIntegrate's shape: a free flyer's block, then the identity
            block = min(size, 6)
            matrix[:block, :block] += 0.3 * rng.normal(size=(block, block))
            rhs, out = rng.normal(size=size), np.empty(size)
            assert dgesv_into(matrix, rhs, out, False) == 0
            assert out.tobytes() == lapack.dgesv(matrix, rhs)[2].tobytes()
    assert dgesv_into(np.ones((3, 3)), np.ones(3), np.empty(3), False) > 0  # info: U_22 = 0


def test_the_kernels_call_numpys_own_dgesv_where_numpy_exports_it():
    numpy_address = numpy_dgesv_address()
    expected = scipy_dgesv_address() if numpy_address is None else numpy_address
    assert llvm.address_of_symbol(NUMPY_SYMBOL) == expected
    assert llvm.address_of_symbol(SCIPY_SYMBOL) == scipy_dgesv_address()


def test_without_numpys_dgesv_the_address_is_none_and_scipys_stands_for_it(monkeypatch):
    import ctypes

    def unopenable(path):
        raise OSError(f"cannot open {path}")

    monkeypatch.setattr(ctypes, "CDLL", unopenable)
    assert numpy_dgesv_address() is None
    assert scipy_dgesv_address() > 0


def test_a_singular_or_non_finite_system_is_refused():
    out = np.empty(3)
    assert not solve_into(np.ones((3, 3)), np.ones(3), out)  # LAPACK's info > 0
    assert not solve_into(np.eye(3), np.array([1.0, np.nan, 0.0]), out)
    assert not solve_into(np.eye(3), np.array([np.inf, 0.0, 0.0]), out)
    assert solve_into(np.zeros((0, 0)), np.zeros(0), np.zeros(0))  # nothing to solve


def test_a_plant_whose_vehicle_acceleration_is_not_finite_raises_instead_of_returning_nan():
    plant = Plant(shipped("bluerov2_alpha5"), gravity=True)
    q, v = plant.robot.configuration(), np.zeros(plant.model.nv)
    command = np.zeros(plant.model.nv - plant.nb)
    assert np.isfinite(plant.stage_acceleration(q, v, command)).all()
    v[0] = np.nan
    with pytest.raises(NumericalError, match="singular or overflowing 6x6 system"):
        plant.stage_acceleration(q, v, command)
