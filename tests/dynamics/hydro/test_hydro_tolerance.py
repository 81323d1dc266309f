"""Published added-mass matrices are rounded: symmetry and definiteness are checked relative to the largest entry.

uuv_simulator's RexROV gives entry (2,5) = 10.774 but (5,2) = 10.775 beside a largest entry of 3,659.9
(2.7e-7 of it): accepted, averaged to (M + M^T) / 2 with a warning naming the link; a clear asymmetry is refused.
"""

from __future__ import annotations

import numpy as np
import pytest

from uvms.dynamics.hydro.hydrodynamics import parse_hydrodynamics
from uvms.dynamics.hydro.parameters import MATRIX_TOLERANCE, LinkHydrodynamics, flip_frd_flu
from uvms.errors import AddedMassSymmetrizedWarning, ModelCheckError

from conftest import body_urdf

#: The RexROV's added mass as uuv_descriptions publishes it (SNAME axes, row-major).
REXROV_ADDED_MASS = np.array([
    [779.79, -6.8773, -103.32, 8.5426, -165.54, -7.8033],
    [-6.8773, 1222, 51.29, 409.44, -5.8488, 62.726],
    [-103.32, 51.29, 3659.9, 6.1112, -386.42, 10.774],
    [8.5426, 409.44, 6.1112, 534.9, -10.027, 21.019],
    [-165.54, -5.8488, -386.42, -10.027, 842.69, -1.1162],
    [-7.8033, 62.726, 10.775, 21.019, -1.1162, 224.32],
])


def text(matrix: np.ndarray) -> str:
    return " ".join(f"{value:.10g}" for value in matrix.ravel())


def test_the_rexrov_added_mass_is_symmetrised_with_a_warning_naming_the_link():
    assert 0.001 / 3659.9 < MATRIX_TOLERANCE
    with pytest.warns(AddedMassSymmetrizedWarning, match=r"rexrov.urdf: hydrodynamics of link 'hull': added_mass "
                      r"is not exactly symmetric \(largest difference 0\.001 between entries \((2,5|5,2)\)"):
        parameters = parse_hydrodynamics(body_urdf(added=text(REXROV_ADDED_MASS)), "rexrov.urdf")
    added = parameters.links["hull"].added_mass
    assert np.array_equal(added, added.T)
    expected = flip_frd_flu(0.5 * (REXROV_ADDED_MASS + REXROV_ADDED_MASS.T))
    assert np.allclose(added, expected, rtol=0, atol=1e-12)
    assert added[2, 5] == added[5, 2] == pytest.approx(10.7745, abs=1e-12)  # w and r both flip: the sign stays
    assert np.min(np.linalg.eigvalsh(added)) > 0


def test_a_symmetric_matrix_gives_no_warning_and_is_kept_exactly(recwarn):
    symmetric = 0.5 * (REXROV_ADDED_MASS + REXROV_ADDED_MASS.T)
    link = LinkHydrodynamics(added_mass=symmetric)
    assert np.array_equal(link.added_mass, symmetric)
    assert not [w for w in recwarn if issubclass(w.category, AddedMassSymmetrizedWarning)]


@pytest.mark.parametrize("difference", [0.05, 10.0])
def test_a_clear_asymmetry_is_still_refused_with_todays_message(difference):
    skewed = REXROV_ADDED_MASS.copy()
    skewed[5, 2] = skewed[2, 5] + difference  # 0.05 in 3,659.9 is 1.4e-5 of the largest entry
    with pytest.raises(ModelCheckError, match=r"rexrov.urdf: hydrodynamics of link 'hull': added_mass must be "
                       r"symmetric: entry \(\d,\d\) = .* but \(\d,\d\) = .*at most 1e-06 of the largest, 3659\.9"):
        parse_hydrodynamics(body_urdf(added=text(skewed)), "rexrov.urdf")


def test_the_dataclass_symmetrises_too_and_still_refuses_an_indefinite_matrix():
    nearly = np.diag([2000.0, 1, 1, 1, 1, 1])
    nearly[0, 1], nearly[1, 0] = 0.5, 0.5 + 1e-4  # 5e-8 of the largest entry
    with pytest.warns(AddedMassSymmetrizedWarning, match="largest difference 0.0001"):
        link = LinkHydrodynamics(added_mass=nearly)
    assert link.added_mass[0, 1] == link.added_mass[1, 0] == pytest.approx(0.50005)
    with pytest.raises(ModelCheckError, match="positive semi-definite; its smallest eigenvalue is -1"):
        LinkHydrodynamics(added_mass=np.diag([3659.9, 1, -1, 1, 1, 1]))
