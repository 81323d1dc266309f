"""The pivoted QR triangle, the few rows with a matrix's Gram matrix, and the iCAT inverse built on them."""

from __future__ import annotations

import numpy as np
import pytest

from uvms.numerics._kernels.icat import eta_rows, level_inverse_into
from uvms.numerics._kernels.qr import gram_rows, pivoted_triangle


def rank_deficient(rng: np.random.Generator, rows: int, size: int, rank: int) -> np.ndarray:
    return rng.standard_normal((rows, rank)) @ rng.standard_normal((rank, size))


@pytest.mark.parametrize("rank", [0, 1, 3, 6])
def test_the_pivoted_triangle_has_the_gram_matrix_of_the_permuted_columns_and_falling_diagonal(rng, rank):
    matrix = rank_deficient(rng, 9, 6, rank) if rank else np.zeros((9, 6))
    upper, order = pivoted_triangle(matrix)
    assert np.array_equal(upper, np.triu(upper)) and sorted(order) == list(range(6))
    permuted = matrix[:, order]
    np.testing.assert_allclose(upper.T @ upper, permuted.T @ permuted, atol=1e-12 * max(1.0, np.abs(matrix).max()) ** 2)
    diagonal = np.abs(np.diag(upper))
    assert np.all(diagonal[1:] <= diagonal[:-1] * (1 + 1e-12) + 1e-12)  # the largest remaining column first
    assert np.all(diagonal[rank:] < 1e-12 * max(1.0, diagonal[0]))  # a rank-r matrix: r rows above rounding


@pytest.mark.parametrize("rank", [1, 2, 5, 8])
def test_gram_rows_give_the_gram_matrix_from_as_many_rows_as_the_rank(rng, rank):
    matrix = rank_deficient(rng, 8, 8, rank)
    rows = gram_rows(matrix, (8 * np.finfo(float).eps) ** 2 * np.sum(matrix**2))
    assert rows.shape == (rank, 8)
    np.testing.assert_allclose(rows.T @ rows, matrix.T @ matrix, atol=1e-12 * np.abs(matrix.T @ matrix).max())


def projector_of(rng: np.random.Generator, size: int, held: int) -> np.ndarray:
    """Q = I - J^+ J of ``held`` random rows: the directions a level above holds, Q their complement."""
    rows = rng.standard_normal((held, size))
    return np.eye(size) - np.linalg.pinv(rows) @ rows


@pytest.mark.parametrize(("active", "held", "task_rank"), [(6, 2, 6), (1, 3, 1), (6, 1, 4), (3, 4, 3)])
def test_the_undamped_level_inverse_with_eta_rows_is_the_pseudo_inverse_of_the_whole_stack(rng, active, held,
                                                                                       task_rank):
    size = 11
    jacobian = rank_deficient(rng, active, size, task_rank)
    jacobian[:, 10] = 0.0  # a column that moves nothing of the level (the jaw of a pose task)
    projector = projector_of(rng, size, held)
    activation = rng.uniform(0.2, 1.0, active)
    unprojected = np.sqrt(activation)[:, None] * jacobian
    scaled = np.ascontiguousarray(unprojected @ projector)
    penalty = eta_rows(unprojected, projector, 1.0)
    power = activation**1.5
    out = np.empty((size, active))
    converged, sigma_min, used = level_inverse_into(scaled, power, penalty, np.empty(0), np.empty((0, 0)), 0.0, 0.0,
                                                    0.0, 1e-12, 0.0, out)
    expected = np.linalg.pinv(np.vstack([scaled, penalty]), rcond=1e-12)[:, :active] * power
    assert converged and sigma_min == 0.0 and used == 0.0  # sigma_min of the tall stack, as without the rows' F
    np.testing.assert_allclose(out, expected, atol=1e-10 * np.abs(expected).max())
