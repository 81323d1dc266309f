"""Links with a mass and no rotational inertia (point masses), and whether the whole model can bear them.

uuv_simulator writes its thruster links as ``<mass value="0.001"/>`` with every inertia entry 0; Gazebo and
Pinocchio accept it, so uvms does too, with a :class:`PointMassWarning`, and refuses only a model whose joint-space
mass matrix is then singular (a joint that would move nothing with inertia: accelerations would be undefined).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from ..errors import ModelCheckError

#: A mass matrix whose smallest eigenvalue is at most this fraction of its largest is singular (rounding of an
#: exactly singular one stays near 1e-16 of it).
SINGULAR_TOLERANCE = 1e-13
#: Irrational fractions that place each coordinate at a generic value within its limits (clipped to +-1):
#: a mass matrix singular there is singular almost everywhere, not only at a special pose.
_GENERIC_FRACTION = (np.sqrt(5.0) - 1.0) / 2.0


def generic_configuration(model: pin.Model) -> np.ndarray:
    """A configuration (nq,) away from the special poses (zero angles, aligned axes), within the limits."""
    lower = np.clip(model.lowerPositionLimit, -1.0, 1.0)
    upper = np.clip(model.upperPositionLimit, -1.0, 1.0)
    upper = np.where(upper > lower, upper, lower)
    fractions = (np.arange(1, model.nq + 1) * _GENERIC_FRACTION) % 1.0
    return pin.normalize(model, lower + fractions * (upper - lower))


def check_mass_matrix(model: pin.Model, point_masses: Sequence[str], origin: str) -> None:
    """Refuse a model with point-mass links whose mass matrix (nv, nv) [kg, kg m, kg m^2] is singular.

    Checked only when the model has point masses (a model without any mass still loads for kinematics, as
    before), at :func:`generic_configuration`; a model Pinocchio cannot compute it for (mimic joints) is left.

    Raises:
        ModelCheckError: the mass matrix is singular, naming the point-mass links and what is valid.
    """
    if not point_masses or model.nv == 0:
        return
    data = model.createData()
    try:
        matrix = pin.crba(model, data, generic_configuration(model))
    except RuntimeError:
        return
    matrix = np.triu(matrix) + np.triu(matrix, 1).T
    eigenvalues = np.linalg.eigvalsh(matrix)
    if not np.all(np.isfinite(eigenvalues)) or eigenvalues[0] <= SINGULAR_TOLERANCE * max(eigenvalues[-1], 0.0):
        raise ModelCheckError(
            f"{origin}: the mass matrix is singular (smallest eigenvalue {eigenvalues[0]:.3g} of largest "
            f"{eigenvalues[-1]:.3g}) with the point-mass link(s) {', '.join(point_masses)} (mass, all-zero "
            "inertia): some joint moves no inertia; give those links a positive definite <inertia> (e.g. of a "
            "small sphere, 2/5 m r^2) or fix the joint that carries them")
