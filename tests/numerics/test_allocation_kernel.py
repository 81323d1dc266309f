"""The thrust allocation's compiled pseudo-inverse step (uvms.numerics._kernels.allocation) gives the numbers of the
numpy expressions it replaced, bit for bit, and takes the same branch."""

from __future__ import annotations

import numpy as np
import pytest

import uvms
from uvms.dynamics.thrusters.allocation import ThrustAllocator
from uvms.dynamics.thrusters.thrusters import allocation_matrix, thrusters_of
from uvms.errors import SolverInputError
from uvms.numerics._kernels.allocation import pseudo_inverse_thrusts


def numpy_step(allocator: ThrustAllocator, wrench: np.ndarray) -> tuple | None:
    """The allocation's pseudo-inverse step as numpy expressions (the code before the kernel): (thrusts, achieved,
    residual, exact) when B^+ tau is within the bounds' slack, else None."""
    thrusts = allocator.inverse @ wrench
    low, high = allocator._inside
    if not ((thrusts >= low).all() and (thrusts <= high).all()):
        return None
    thrusts = np.minimum(np.maximum(thrusts, allocator.lower), allocator.upper)
    achieved = allocator.matrix @ thrusts
    residual = wrench - achieved
    exact = np.abs(residual).max() <= 10 * allocator.tolerance * max(1.0, np.abs(wrench).max())
    return thrusts, achieved, residual, bool(exact)


def kernel_step(allocator: ThrustAllocator, wrench: np.ndarray) -> tuple | None:
    thrusts, achieved, residual = np.empty(allocator.n), np.empty(6), np.empty(6)
    finite, within, exact = pseudo_inverse_thrusts(
        allocator.inverse, allocator.matrix, wrench, *allocator._inside, allocator.lower, allocator.upper,
        allocator.tolerance, thrusts, achieved, residual)
    assert finite
    return (thrusts, achieved, residual, exact) if within else None


def test_the_compiled_step_equals_numpy_bit_for_bit_on_the_bluerov2_and_a_one_way_thruster():
    robot = uvms.load("bluerov2_alpha5")
    thrusters = thrusters_of(robot)
    matrix = allocation_matrix(robot, thrusters)  # F-ordered (6, 8), as the chain's
    lower = thrusters.lower.copy()
    one_way = lower.copy()
    one_way[0] = 0.0  # a thruster that only pushes: np.maximum between 0 and -0 picks numpy's zero
    rng = np.random.default_rng(7)
    for bounds in (lower, one_way):
        allocator = ThrustAllocator(matrix, bounds, thrusters.upper, priorities=[("z", "roll", "pitch", "yaw"),
                                                                                 ("x", "y")])
        branches, clipped = set(), 0
        for trial in range(3000):
            wrench = matrix @ rng.uniform(1.3 * bounds, 1.3 * thrusters.upper)  # some outside the bounds
            if trial % 5 == 0:  # B^+ tau exactly zero or negative zero on some thrusters
                wrench = -0.0 * wrench if trial % 2 else 0.0 * wrench
            if trial % 7 == 0:
                wrench = wrench + rng.standard_normal(6) * 1e-8  # off B's range by little: exact or not
            if trial % 11 == 1 and np.any(wrench):  # B^+ tau beyond a bound by less than the slack: clipped to it
                thrusts = allocator.inverse @ wrench
                ratio = max(np.max(thrusts / thrusters.upper), np.max(thrusts[bounds < 0] / bounds[bounds < 0]))
                wrench = wrench * ((1.0 + 4e-10 / np.max(np.abs(thrusts))) / ratio)
            old, new = numpy_step(allocator, wrench), kernel_step(allocator, wrench)
            assert (old is None) == (new is None)
            branches.add(old is None)
            if old is not None:
                clipped += bool(np.any(old[0] != allocator.inverse @ wrench))
                for a, b in zip(old[:3], new[:3]):
                    assert a.tobytes() == b.tobytes()  # signed zeros included
                assert old[3] == new[3]
        assert branches == {True, False}
        assert clipped > 50


def test_allocate_refuses_a_wrench_that_is_not_finite_as_before():
    robot = uvms.load("bluerov2_alpha5")
    thrusters = thrusters_of(robot)
    allocator = ThrustAllocator(allocation_matrix(robot, thrusters), thrusters.lower, thrusters.upper)
    finite, _, _ = pseudo_inverse_thrusts(
        allocator.inverse, allocator.matrix, np.array([0.0, np.nan, 0, 0, 0, 0]), *allocator._inside,
        allocator.lower, allocator.upper, allocator.tolerance, np.empty(allocator.n), np.empty(6), np.empty(6))
    assert not finite
    for bad in (np.array([0.0, np.inf, 0, 0, 0, 0]), [0.0, 0.0, np.nan, 0.0, 0.0, 0.0], [1.0, 2.0]):
        with pytest.raises(SolverInputError, match="wrench"):
            allocator.allocate(bad)
    # a strided view of a valid wrench is allocated as its copy
    wide = np.zeros(12)
    wide[::2] = allocation_matrix(robot, thrusters) @ np.full(8, 1.0)
    np.testing.assert_array_equal(allocator.allocate(wide[::2]).thrusts, allocator.allocate(wide[::2].copy()).thrusts)


def test_each_allocation_returns_arrays_of_its_own():
    """The kernel writes into arrays allocate makes per call: a result kept (a record's row) keeps its numbers when
    the next allocation runs; nothing saturated (read-only, shared) on the pseudo-inverse path."""
    robot = uvms.load("bluerov2_alpha5")
    thrusters = thrusters_of(robot)
    allocator = ThrustAllocator(allocation_matrix(robot, thrusters), thrusters.lower, thrusters.upper)
    first = allocator.allocate(allocator.matrix @ np.full(8, 1.0))
    kept = [first.thrusts.copy(), first.achieved_wrench.copy(), first.residual.copy()]
    second = allocator.allocate(allocator.matrix @ np.full(8, -2.0))
    assert first.solver == second.solver == "pinv"
    for before, after in zip(kept, (first.thrusts, first.achieved_wrench, first.residual)):
        assert before.tobytes() == after.tobytes()
    np.testing.assert_allclose(second.achieved_wrench, allocator.matrix @ np.full(8, -2.0), atol=1e-9)
    assert not first.saturated.any() and not first.saturated.flags.writeable
