"""One level of the QP hierarchy: DAQP through its own API, the level's QP written by one compiled call."""

from __future__ import annotations

import numpy as np
import pytest

qpsolvers = pytest.importorskip("qpsolvers")


def random_qp(rng: np.random.Generator, size: int, rows: int) -> tuple[np.ndarray, ...]:
    """A strictly convex QP with a box holding 0 and rows G z <= h that z = 0 meets (feasible)."""
    factor = rng.normal(size=(size, size))
    cost = factor @ factor.T + 0.1 * np.eye(size)
    linear = rng.normal(size=size) * 3.0
    matrix = rng.normal(size=(rows, size))
    bounds = rng.uniform(0.1, 1.0, rows)
    lower, upper = -rng.uniform(0.2, 2.0, size), rng.uniform(0.2, 2.0, size)
    upper[rng.integers(size)] = np.inf
    return cost, linear, matrix, bounds, lower, upper


def qpsolvers_solution(cost, linear, matrix, bounds, lower, upper, solver, **options):
    problem = qpsolvers.Problem(cost, linear, matrix if matrix.size else None, bounds if matrix.size else None,
                                None, None, lower, upper)
    return qpsolvers.solve_problem(problem, solver=solver, **options).x


@pytest.mark.skipif("daqp" not in qpsolvers.available_solvers, reason="DAQP not installed")
@pytest.mark.filterwarnings("ignore:Converted matrix")  # qpsolvers converting for Clarabel
@pytest.mark.parametrize("options", [{}, {"eps_prox": 1e-6}])
def test_daqp_through_its_own_api_is_qpsolvers_daqp_bit_for_bit_and_another_solvers_optimum(rng, options):
    """solve_qp's direct DAQP call gives qpsolvers' DAQP solution to the last bit (the same arrays reach the same C
    solver), and the optimum an independent solver (Clarabel, interior point) finds, to its tolerance."""
    from uvms.solvers.cascade import solve_qp

    independent = next((name for name in ("clarabel", "proxqp", "osqp") if name in qpsolvers.available_solvers),
                       None)
    for trial in range(60):
        size, count = int(rng.integers(2, 14)), int(rng.integers(0, 9))
        cost, linear, matrix, bounds, lower, upper = random_qp(rng, size, count)
        inputs = (cost, linear, matrix, np.concatenate([upper, bounds]), np.concatenate([lower, np.full(count, -1e30)]))
        copies = [array.copy() for array in inputs]
        z = solve_qp(*inputs, "daqp", options)
        expected = qpsolvers_solution(cost, linear, matrix, bounds, lower, upper, "daqp", **options)
        assert z is not None and np.array_equal(z, expected), trial
        assert all(np.array_equal(a, b) for a, b in zip(inputs, copies))  # a level's retries reuse its arrays
        assert np.all(matrix @ z <= bounds + 1e-9) and np.all(z >= lower - 1e-12) and np.all(z <= upper + 1e-12)
        if independent is not None:
            other = qpsolvers_solution(cost, linear, matrix, bounds, lower, upper, independent)
            assert np.abs(z - other).max() <= 1e-5 * max(1.0, np.abs(other).max()), (trial, independent)


@pytest.mark.skipif("daqp" not in qpsolvers.available_solvers, reason="DAQP not installed")
def test_an_infeasible_qp_is_not_found_by_either_path():
    from uvms.solvers.cascade import solve_qp

    cost, linear = np.eye(2), np.zeros(2)
    matrix, bounds = np.array([[1.0, 0.0]]), np.array([-2.0])  # z_0 <= -2 inside the box |z| <= 1: empty
    box = np.ones(2)
    assert solve_qp(cost, linear, matrix, np.concatenate([box, bounds]), np.concatenate([-box, [-1e30]]),
                    "daqp") is None
    assert qpsolvers_solution(cost, linear, matrix, bounds, -box, box, "daqp") is None


def test_the_compiled_level_qp_is_the_numpy_one_bit_for_bit(rng):
    """level_qp_into writes the QP over z = [x, w] that numpy builds block by block: P = [[E^T E + r W, 0], [0, I]],
    c = [-E^T r_k, 0], box [lower, 0] <= z <= [upper, inf], rows [[K, 0], [-G, -I]] z <= [h + t (1 + |h|), -b]."""
    from uvms.numerics._kernels.qp import level_qp_into, loosened_bounds_into

    for _ in range(40):
        n, m, k, tasks = (int(rng.integers(1, 12)), int(rng.integers(0, 5)), int(rng.integers(0, 10)),
                          int(rng.integers(0, 7)))
        equality, command = rng.normal(size=(tasks, n)), rng.normal(size=tasks)
        kept_rows, kept = rng.normal(size=(k, n)), rng.normal(size=k) * 10.0 ** rng.integers(-3, 3)
        inequality, bound = rng.normal(size=(m, n)), rng.normal(size=m)
        weights, regularization = np.diag(rng.uniform(0.5, 2.0, n)), 10.0 ** rng.uniform(-9, -1)
        lower_x, upper_x = -rng.uniform(0.1, 1.0, n), rng.uniform(0.1, 1.0, n)
        cost, rows = np.zeros((n + m, n + m)), np.zeros((k + m, n + m))
        linear, upper, lower = np.empty(n + m), np.empty(n + m + k + m), np.empty(n + m + k + m)
        level_qp_into(equality.T @ equality + regularization * weights, -equality.T @ command, kept_rows, kept, 1e-9,
                      inequality, bound, lower_x, upper_x, cost, linear, rows, upper, lower)
        expected_cost = np.zeros((n + m, n + m))
        expected_cost[:n, :n] = equality.T @ equality + regularization * weights
        expected_cost[n:, n:] = np.eye(m)
        expected_rows = np.vstack([np.hstack([kept_rows, np.zeros((k, m))]), np.hstack([-inequality, -np.eye(m)])])
        assert np.array_equal(cost, expected_cost) and np.array_equal(rows, expected_rows)
        assert np.array_equal(linear, np.concatenate([-equality.T @ command, np.zeros(m)]))
        assert np.array_equal(lower, np.concatenate([lower_x, np.zeros(m), np.full(k + m, -1e30)]))
        assert np.array_equal(upper, np.concatenate([upper_x, np.full(m, np.inf), kept + 1e-9 * (1.0 + np.abs(kept)),
                                                     -bound]))
        loosened_bounds_into(kept, 1e-4, n + m, upper)  # a retry with the levels above kept looser
        assert np.array_equal(upper[n + m:n + m + k], kept + 1e-4 * (1.0 + np.abs(kept)))


def test_the_attempts_start_with_the_solver_chosen_then_retry_looser():
    from uvms.solvers.cascade import KEEP_TOLERANCE, level_attempts

    attempts = level_attempts(["daqp", "proxqp"])
    assert attempts[0] == ("daqp", {}, KEEP_TOLERANCE) and attempts[1] == ("daqp", {"eps_prox": 1e-6}, KEEP_TOLERANCE)
    assert [tolerance for _, _, tolerance in attempts[2:4]] == [1e-6, 1e-4] and attempts[-1] == ("proxqp", {}, 1e-9)
