"""Thrust allocation (uvms.dynamics.thrusters.allocation): exact when attainable, the bounded least-squares optimum
when not."""

from __future__ import annotations

from ctypes import c_int

import numpy as np
import pytest
from scipy.optimize import lsq_linear, minimize

import uvms
from uvms.dynamics.thrusters.allocation import ThrustAllocator
from uvms.dynamics.thrusters.thrusters import allocation_matrix, thrusters_of
from uvms.errors import SolverInputError

from conftest import THRUSTER_BOX


@pytest.fixture(scope="module", params=["box", "bluerov2_alpha5"])
def vehicle(request):
    robot = uvms.load(THRUSTER_BOX if request.param == "box" else request.param)
    thrusters = thrusters_of(robot)
    return allocation_matrix(robot, thrusters), thrusters.lower, thrusters.upper


def test_random_attainable_wrenches_are_reproduced_without_a_solver(vehicle):
    matrix, lower, upper = vehicle
    allocator = ThrustAllocator(matrix, lower, upper)
    rng = np.random.default_rng(1)
    for _ in range(200):
        thrusts = rng.uniform(0.3 * lower, 0.3 * upper)  # well inside: B^+ B f stays inside too
        wrench = matrix @ thrusts
        result = allocator.allocate(wrench)
        assert result.solver == "pinv" and result.attainable and not result.saturated.any()
        np.testing.assert_allclose(result.achieved_wrench, wrench, rtol=0, atol=1e-9)
        np.testing.assert_allclose(result.thrusts, np.linalg.pinv(matrix) @ wrench, atol=1e-9)  # minimum norm


def test_attainable_wrench_whose_pinv_solution_saturates_is_found_by_the_bounded_stage(vehicle):
    """Near a thruster's limit B^+ tau leaves the bounds although another allocation attains tau exactly."""
    matrix, lower, upper = vehicle
    allocator = ThrustAllocator(matrix, lower, upper)
    rng = np.random.default_rng(2)
    found = 0
    for _ in range(300):
        wrench = matrix @ rng.uniform(lower, upper)  # attainable by construction
        result = allocator.allocate(wrench)
        assert np.all(result.thrusts >= lower - 1e-9) and np.all(result.thrusts <= upper + 1e-9)
        np.testing.assert_allclose(result.achieved_wrench, wrench, rtol=0, atol=1e-7)
        assert result.attainable
        found += result.solver == "bounded"
    assert found > 10


def _slsqp_optimum(matrix, lower, upper, wrench):
    """min |B f - tau|^2 s.t. bounds by SLSQP: an independent solver."""
    start = np.clip(np.linalg.pinv(matrix) @ wrench, lower, upper)
    result = minimize(lambda f: 0.5 * np.sum((matrix @ f - wrench) ** 2), start,
                      jac=lambda f: matrix.T @ (matrix @ f - wrench), bounds=list(zip(lower, upper)),
                      method="SLSQP", options={"ftol": 1e-15, "maxiter": 500})
    return result.x


def test_unattainable_wrenches_give_the_bounded_least_squares_optimum(vehicle):
    matrix, lower, upper = vehicle
    allocator = ThrustAllocator(matrix, lower, upper)
    rng = np.random.default_rng(3)
    for _ in range(30):
        wrench = rng.normal(size=6) * np.array([250, 250, 250, 40, 40, 40])
        result = allocator.allocate(wrench)
        assert not result.attainable and result.saturated.any()
        assert np.all(result.thrusts >= lower - 1e-9) and np.all(result.thrusts <= upper + 1e-9)
        np.testing.assert_allclose(result.residual, wrench - result.achieved_wrench, atol=1e-12)
        trf = lsq_linear(matrix, wrench, bounds=(lower, upper), method="trf", tol=1e-13).x  # another method
        slsqp = _slsqp_optimum(matrix, lower, upper, wrench)  # and another solver
        for other in (trf, slsqp):  # the optimum wrench is unique: no other method does better, and the closer
            # another feasible point's residual comes to ours, the closer its wrench: at the optimum of a convex
            # least squares |r_other|^2 >= |r_ours|^2 + |B f_other - B f_ours|^2 (SLSQP stops ~1e-8 short here)
            gap = np.sum((wrench - matrix @ other) ** 2) - np.sum(result.residual**2)
            assert np.sum((matrix @ other - result.achieved_wrench) ** 2) <= gap + 1e-6
            np.testing.assert_allclose(result.achieved_wrench, matrix @ other, atol=1e-2)
        # the least-norm stage: no smaller thrust vector gives the same wrench
        assert np.linalg.norm(result.thrusts) <= np.linalg.norm(trf) + 1e-6


def test_priorities_keep_the_higher_group_first(vehicle):
    """Heading, depth and attitude before surge and sway (yaw and surge share the horizontal thrusters): the first
    group is attained whenever it can be on its own, the second is the best the rest allows."""
    matrix, lower, upper = vehicle
    groups = [("yaw", "z", "roll", "pitch"), ("x", "y")]
    allocator = ThrustAllocator(matrix, lower, upper, priorities=groups)
    plain = ThrustAllocator(matrix, lower, upper)
    first, second = [5, 2, 3, 4], [0, 1]
    rng = np.random.default_rng(4)
    improved = 0
    for _ in range(20):
        wrench = np.zeros(6)
        wrench[first] = matrix[first] @ rng.uniform(0.8 * lower, 0.8 * upper)  # attainable on its own
        wrench[second] = rng.normal(size=2) * 400  # far beyond the horizontals
        result = allocator.allocate(wrench)
        np.testing.assert_allclose(result.achieved_wrench[first], wrench[first], atol=1e-6)
        assert np.all(result.thrusts >= lower - 1e-9) and np.all(result.thrusts <= upper + 1e-9)
        best = _second_stage_optimum(matrix, lower, upper, wrench, first, second)
        np.testing.assert_allclose(np.linalg.norm(result.residual[second]), best, rtol=1e-4, atol=1e-6)
        improved += np.linalg.norm(plain.allocate(wrench).residual[first]) > 1e-3
    assert improved > 10  # without priorities the first group would have been given up


def _second_stage_optimum(matrix, lower, upper, wrench, first, second):
    """min |B_2 f - tau_2| s.t. B_1 f = tau_1 and bounds, by SLSQP (the first group attainable)."""
    start = lsq_linear(matrix[first], wrench[first], bounds=(lower, upper), method="bvls").x
    constraint = {"type": "eq", "fun": lambda f: matrix[first] @ f - wrench[first], "jac": lambda f: matrix[first]}
    result = minimize(lambda f: 0.5 * np.sum((matrix[second] @ f - wrench[second]) ** 2), start,
                      jac=lambda f: matrix[second].T @ (matrix[second] @ f - wrench[second]),
                      bounds=list(zip(lower, upper)), constraints=[constraint], method="SLSQP",
                      options={"ftol": 1e-15, "maxiter": 1000})
    return float(np.linalg.norm(matrix[second] @ result.x - wrench[second]))


def test_bad_allocation_input():
    matrix = np.eye(6)
    with pytest.raises(SolverInputError, match="lower <= 0 <= upper"):
        ThrustAllocator(matrix, np.ones(6), np.full(6, 2.0))
    with pytest.raises(SolverInputError, match="unknown task axis 'surge'"):
        ThrustAllocator(matrix, -np.ones(6), np.ones(6), priorities=[("surge",)])
    with pytest.raises(SolverInputError, match="6 numbers"):
        ThrustAllocator(matrix, -np.ones(6), np.ones(6)).allocate(np.zeros(5))
    with pytest.raises(SolverInputError, match="finite"):
        ThrustAllocator(matrix, -np.ones(6), np.ones(6)).allocate(np.array([np.nan, 0, 0, 0, 0, 0]))


def near_singular_layout(offsets=(1e-9, -2e-9, 5e-10, 3e-9)) -> np.ndarray:
    """B (6, 6) of a six-thruster vehicle with no roll authority: four vectored horizontal thrusters and two
    verticals on the centre line, the horizontals placed ``offsets`` [m] off z = 0 (the rounding of xacro sums)."""
    s = np.sqrt(0.5)
    layout = [((0.6, -0.4, offsets[0]), (s, s, 0)), ((0.6, 0.4, offsets[1]), (s, -s, 0)),
              ((-0.6, -0.4, offsets[2]), (-s, s, 0)), ((-0.6, 0.4, offsets[3]), (-s, -s, 0)),
              ((0.5, 0.0, 0.0), (0, 0, 1)), ((-0.5, 0.0, 0.0), (0, 0, 1))]
    return np.column_stack([np.concatenate([d, np.cross(p, d)]) for p, d in
                            ((np.array(p), np.array(d, float)) for p, d in layout)])


def test_a_direction_given_only_by_rounding_is_unreachable_and_no_thrusters_fight_for_it():
    """cond(B) = 8e9 and numpy counts rank 6: the old allocation drove the four horizontal thrusters to about -2000 N
    (one at its limit) to produce 3 N m of roll from 1e-9 m lever arms. Judged at RANK_TOLERANCE, roll is
    unreachable; the thrusts are the least-norm ones of the exact layout (no offsets) and the roll moment is left."""
    matrix = near_singular_layout()
    assert np.linalg.matrix_rank(matrix) == 6 and np.linalg.cond(matrix) > 1e9
    bound = np.full(6, 2000.0)
    allocator = ThrustAllocator(matrix, -bound, bound)
    assert allocator.rank == 5 and len(allocator.unreachable) == 1
    roll = allocator.unreachable[0]
    assert roll.axis == "roll" and roll.thrusters == (0, 1, 2, 3) and 1e-11 < roll.ratio < 1e-9
    np.testing.assert_allclose(np.abs(roll.wrench), [0, 0, 0, 1, 0, 0], atol=1e-8)
    wrench = np.array([50.0, 20.0, 100.0, 3.0, 10.0, 5.0])
    result = allocator.allocate(wrench)
    exact = near_singular_layout(offsets=(0.0, 0.0, 0.0, 0.0))  # rank 5 exactly
    least_norm = np.linalg.lstsq(exact, wrench, rcond=None)[0]
    np.testing.assert_allclose(result.thrusts, least_norm, atol=1e-6)
    assert np.abs(result.thrusts).max() < 70 and not result.saturated.any() and result.solver == "pinv"
    np.testing.assert_allclose(result.residual, [0, 0, 0, 3.0, 0, 0], atol=1e-6)
    assert not result.attainable
    # beyond the layout's surge (5657 N) the bounded stages run on the reachable directions: the horizontals push
    # together at their limits, the verticals stay at 0, and no thrust is spent on the unreachable roll
    strong = allocator.allocate(np.array([8000.0, 0.0, 0.0, 50.0, 0.0, 0.0]))
    assert strong.solver == "bounded"
    np.testing.assert_allclose(strong.thrusts, [2000, 2000, -2000, -2000, 0, 0], atol=1e-4)  # DAQP: 4e-6 N
    assert abs(strong.achieved_wrench[0] - 4 * np.sqrt(0.5) * 2000) < 1e-6 and abs(strong.achieved_wrench[3]) < 1e-4


def test_a_full_layout_reaches_every_direction_and_says_nothing(vehicle):
    allocator = ThrustAllocator(*vehicle)
    assert allocator.rank == 6 and allocator.unreachable == () and allocator.reach_note(["t"] * allocator.n) == ""
    np.testing.assert_allclose(allocator.reachable, vehicle[0], atol=1e-12)


def test_the_bounded_stages_give_the_thrusts_of_qpsolvers_daqp_bit_for_bit(vehicle):
    """The QP stages call DAQP's own API with the arrays qpsolvers' DAQP interface builds: the thrusts of
    ``qpsolvers.solve_qp(..., solver="daqp")`` on the same stages, bit for bit (saturated, prioritized wrenches)."""
    from qpsolvers import solve_qp

    matrix, lower, upper = vehicle
    allocator = ThrustAllocator(matrix, lower, upper, priorities=[("yaw", "z", "roll", "pitch"), ("x", "y")])

    class ThroughQPSolvers(ThrustAllocator):
        def _solve_qp(self, p, q, rows, thrusts):
            a, b = independent_rows(rows.matrix, rows.matrix @ thrusts)
            solution = solve_qp(p, q, A=a, b=b, lb=self.lower, ub=self.upper, solver="daqp", eps_prox=1e-6)
            return thrusts if solution is None or not np.all(np.isfinite(solution)) else solution

    reference = ThroughQPSolvers(matrix, lower, upper, priorities=[("yaw", "z", "roll", "pitch"), ("x", "y")])
    rng = np.random.default_rng(7)
    bounded = 0
    for _ in range(30):
        wrench = rng.normal(size=6) * np.array([300.0, 300.0, 300.0, 30.0, 30.0, 30.0])
        result, expected = allocator.allocate(wrench), reference.allocate(wrench)
        assert np.array_equal(result.thrusts, expected.thrusts)
        bounded += result.solver == "bounded"
    assert bounded > 20  # the QP stages ran


def independent_rows(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A x = b reduced to its independent rows, computed at every call (the allocation before its rows were
    prepared once)."""
    u, singular, vt = np.linalg.svd(a, full_matrices=False)
    rank = int(np.sum(singular > 1e-10 * max(1.0, singular[0] if singular.size else 0.0)))
    return vt[:rank], (u[:, :rank].T @ b) / singular[:rank]


class PerCall(ThrustAllocator):
    """The bounded stages as they were before their fixed arrays were prepared once: every array, rank and SVD
    computed at each call, scipy's lsq_linear called for the first group."""

    def _lexicographic(self, wrench):
        from scipy.optimize import lsq_linear

        kept, thrusts = [], None
        for group in self.groups:
            weights = self.weights[group][:, None]
            a, b = weights * self.reachable[group], self.weights[group] * wrench[group]
            if not kept:
                thrusts = lsq_linear(a, b, bounds=(self.lower, self.upper), method="bvls", tol=1e-12).x
            else:
                thrusts = self._qp(a.T @ a, -a.T @ b, self.reachable[kept], self.reachable[kept] @ thrusts, thrusts)
            thrusts = np.clip(thrusts, self.lower, self.upper)
            kept += list(group)
        return thrusts

    def _least_norm(self, thrusts):
        rows = self.reachable[self._rows]
        singular = np.linalg.svd(rows, compute_uv=False)
        if self.n <= int(np.sum(singular > 1e-6 * singular[0])):
            return thrusts
        return np.clip(self._qp(np.eye(self.n), np.zeros(self.n), rows, rows @ thrusts, thrusts), self.lower,
                       self.upper)

    def _qp(self, p, q, a, b, start):
        import daqp

        a, b = independent_rows(a, b)
        n, equalities = self.n, a.shape[0]
        upper, lower = np.empty(n + equalities), np.full(n + equalities, -1e30)
        upper[:n], lower[:n], upper[n:] = self.upper, self.lower, b
        sense = np.zeros(n + equalities, dtype=c_int)
        sense[n:] = 5
        solution, _, exitflag, _ = daqp.solve(p, q, a if equalities else np.zeros((0, n)), upper, lower, sense,
                                              primal_start=None, eps_prox=1e-6)
        return start if exitflag <= 0 or not np.all(np.isfinite(solution)) else solution


@pytest.mark.parametrize("priorities, weights", [(None, None), ([("z", "roll", "pitch", "yaw"), ("x", "y")], None),
                                                 ([("x", "y", "z"), ("roll", "pitch", "yaw")], [1, 2, 1, 5, 5, 3])])
def test_the_prepared_bounded_stages_give_the_per_call_numbers_bit_for_bit(vehicle, priorities, weights):
    """The bounded stages read arrays prepared at their first call (each group's weighted rows and QP, the kept rows'
    independent form, DAQP's bounds) and take lsq_linear's unbounded step when it lies within the bounds: every
    result equals the one of those computed at each call, the first group in and out of the bounds."""
    matrix, lower, upper = vehicle
    options = dict(priorities=priorities, weights=None if weights is None else np.array(weights, dtype=float))
    prepared, per_call = ThrustAllocator(matrix, lower, upper, **options), PerCall(matrix, lower, upper, **options)
    rng = np.random.default_rng(11)
    bounded, first_outside = 0, 0
    for trial in range(60):
        wrench = rng.normal(size=6) * np.array([300.0, 300.0, 300.0, 30.0, 30.0, 30.0]) * (1 + trial % 4)
        result, expected = prepared.allocate(wrench), per_call.allocate(wrench)
        for name in ("thrusts", "achieved_wrench", "residual", "saturated"):
            assert getattr(result, name).tobytes() == getattr(expected, name).tobytes(), name
        assert (result.attainable, result.solver) == (expected.attainable, expected.solver)
        bounded += result.solver == "bounded"
        stage = prepared._bounded.stages[0] if prepared._bounded is not None else None
        if stage is not None and result.solver == "bounded":
            unbounded = np.linalg.lstsq(stage.matrix, stage.weights * wrench[stage.group], rcond=-1)[0]
            first_outside += not np.all((unbounded >= lower) & (unbounded <= upper))
    assert bounded > 20 and first_outside > 5
    problem = prepared._bounded  # DAQP and the stages left the prepared arrays as they were made
    again = ThrustAllocator(matrix, lower, upper, **options)._prepare()
    for mine, fresh in zip(problem.stages, again.stages):
        for name in ("weights", "matrix", "hessian", "negated"):
            assert np.array_equal(getattr(mine, name), getattr(fresh, name)) or getattr(mine, name) is None
    for rows in [problem.rows] + [stage.kept for stage in problem.stages]:
        if rows is not None:
            assert np.array_equal(rows.upper[:len(lower)], upper) and np.array_equal(rows.lower[:len(lower)], lower)
            assert np.all(rows.sense[len(lower):] == 5) and np.all(rows.sense[:len(lower)] == 0)
    assert np.array_equal(problem.identity, np.eye(len(lower))) and not problem.zeros.any()
