"""The compiled command of an equality level (uvms.numerics._kernels.command): prepared_gain's numbers, scalar K."""

from __future__ import annotations

import numpy as np

from uvms.numerics.checks import prepared_gain


def test_command_into_writes_xdot_d_plus_k_e_of_a_scalar_gain_into_a_view():
    from uvms.numerics._kernels.command import command_into

    rng = np.random.default_rng(3)
    for size in (1, 3, 6):
        for gain in (0.0, 1.0, 2.5):
            error, feedforward = rng.normal(size=size), rng.normal(size=size)
            stack = np.full(size + 2, 9.0)
            command_into(error, feedforward, gain, stack[1:-1])
            np.testing.assert_allclose(stack[1:-1], prepared_gain(gain, size)(error, feedforward), rtol=1e-15, atol=0)
            assert stack[0] == 9.0 and stack[-1] == 9.0  # nothing written outside the view
