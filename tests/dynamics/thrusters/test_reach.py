"""What a thruster layout reaches (uvms.dynamics.thrusters.reach): the directions left out named the same whatever
basis LAPACK gives their span in."""

import numpy as np

from uvms.dynamics.thrusters.reach import axis_ordered, rank, reachable_directions

#: Two exactly unreachable directions, each mixing two axes: sway with yaw, heave with pitch (a torpedo's fin cross
#: at speed leaves these two).
SWAY_YAW = np.array([0.0, 0.6, 0.0, 0.0, 0.0, 0.8])
HEAVE_PITCH = np.array([0.0, 0.0, -0.6, 0.0, 0.8, 0.0])


def layout() -> np.ndarray:
    """B (6, 5) whose left null space is span(SWAY_YAW, HEAVE_PITCH): five columns spanning its complement."""
    null = np.column_stack([SWAY_YAW, HEAVE_PITCH])
    complement = np.linalg.svd(null, full_matrices=True)[0][:, 2:]  # (6, 4) orthonormal, orthogonal to both
    return complement @ np.random.default_rng(3).normal(size=(4, 5)) * 10.0


def test_the_basis_of_an_unreachable_span_does_not_depend_on_the_basis_given():
    null = np.column_stack([SWAY_YAW, HEAVE_PITCH])
    expected = axis_ordered(null)
    for angle in np.linspace(0.0, 2 * np.pi, 13):
        turn = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
        given = null @ turn * np.array([1.0, -1.0 if angle > 3.0 else 1.0])  # any rotation, either orientation
        basis = axis_ordered(given)
        assert np.allclose(np.abs(basis), np.abs(expected), atol=1e-12)  # the same vectors, up to their sign
        assert np.allclose(basis.T @ basis, np.eye(2), atol=1e-12)
    # the first vector is the span's part along the first axis it holds (y), the second what is left (z)
    assert np.allclose(np.abs(expected[:, 0]), np.abs(SWAY_YAW), atol=1e-12)
    assert np.allclose(np.abs(expected[:, 1]), np.abs(HEAVE_PITCH), atol=1e-12)


def test_the_directions_left_out_are_named_in_axis_order():
    matrix = layout()
    assert rank(matrix) == 4
    reachable, unreachable = reachable_directions(matrix)
    assert [direction.axis for direction in unreachable] == ["pitch", "yaw"]  # named by the largest component
    assert all(direction.ratio == 0.0 and direction.thrusters == () for direction in unreachable)
    wrenches = np.array([direction.wrench for direction in unreachable])
    assert np.allclose(wrenches @ matrix, 0.0, atol=1e-12)  # nothing of B along them
    assert np.allclose(np.abs(wrenches), np.abs([HEAVE_PITCH, SWAY_YAW]), atol=1e-12)
    assert np.allclose(reachable, matrix, atol=1e-12)  # B keeps its four directions
