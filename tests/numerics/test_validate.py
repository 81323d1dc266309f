"""The shared validators (uvms.numerics.validate): each refuses what is invalid with the caller's error class, and
passes valid input."""

from __future__ import annotations

import numpy as np
import pytest

from uvms.errors import ConfigurationError, UVMSError, WorkspaceInputError
from uvms.numerics.validate import finite_array, positive_number, time_vector


def test_finite_array():
    assert finite_array([1, 2, 3], "v", (3,)).dtype == float
    assert finite_array(np.zeros((5, 3)), "p", (None, 3)).shape == (5, 3)
    with pytest.raises(ConfigurationError, match=r"v must have shape \(3,\), got \(2,\)"):
        finite_array([1, 2], "v", (3,), error=ConfigurationError)
    with pytest.raises(WorkspaceInputError, match=r"shape \(N, 3\)"):
        finite_array(np.zeros((5, 2)), "p", (None, 3), error=WorkspaceInputError)
    with pytest.raises(UVMSError, match=r"non-finite entries at \[1\]"):
        finite_array([0.0, np.nan, 1.0], "v")
    with pytest.raises(UVMSError, match="vector of 2 numbers"):
        finite_array(["a", "b"], "v", (2,))


@pytest.mark.parametrize("bad", [0, -1.0, np.inf, np.nan, True, "1", None])
def test_positive_number_refuses(bad):
    with pytest.raises(WorkspaceInputError, match="voxel must be a finite number > 0 \\[m\\]"):
        positive_number(bad, "voxel", unit=" [m]", error=WorkspaceInputError)


def test_positive_number_and_time_vector_accept():
    assert positive_number(np.float32(0.5), "h") == 0.5 and positive_number(0, "h", allow_zero=True) == 0.0
    assert time_vector([0, 1, 1], strict=False).tolist() == [0, 1, 1]
    with pytest.raises(UVMSError, match="strictly increasing"):
        time_vector([0, 1, 1])
    with pytest.raises(UVMSError, match="needs 4 values"):
        time_vector([0, 1, 2], count=4)
