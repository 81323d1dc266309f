"""Hydrodynamic parameters of the links of a UVMS as uvms holds them: buoyancy, added mass, damping (Fossen).

Where they come from (a uuv_simulator block in the URDF or a YAML file) and the conventions of those files:
:mod:`uvms.dynamics.hydro.hydrodynamics` and README.md, "Hydrodynamics of your vehicle".

Conventions inside uvms
-----------------------
Everything in the link frame, FLU (REP-103), [linear; angular] like Pinocchio's
spatial vectors, about the link frame origin: ``added_mass`` M_A (6, 6) symmetric
positive semi-definite, and damping *coefficients* d_l, d_f, d_q >= 0 so that the
damping wrench on the link is -(diag(d_l) + u diag(d_f) + diag(d_q) |nu_r|) nu_r, u the
surge speed relative to the water (uuv_simulator's forward-speed term, ``HMFossen.cc``). The
conversion from the file is M_A = T M_file T with T = diag(1, -1, -1, 1, -1, -1)
and d = -file values (a diagonal is the same in FRD and FLU, and so is u).
"""

from __future__ import annotations

import warnings
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, replace

import numpy as np

from ...errors import AddedMassSymmetrizedWarning, ModelCheckError, NameNotFound

#: Fluid density of sea water [kg/m^3] (uuv_simulator's default) and gravity [m/s^2].
SEA_WATER_DENSITY = 1028.0
GRAVITY = 9.81
#: Sign flip between SNAME (FRD) and ROS (FLU) body axes, per entry of [u v w p q r].
FRD_FLU_SIGNS = np.array([1.0, -1.0, -1.0, 1.0, -1.0, -1.0])
#: Tolerance of the symmetry and semi-definiteness checks of an added-mass matrix, relative to its largest entry
#: (at least 1): published matrices are rounded (uuv_simulator's RexROV differs by 0.001 in 3,659, 2.7e-7 of it).
MATRIX_TOLERANCE = 1e-6


@dataclass(frozen=True)
class LinkHydrodynamics:
    """Hydrostatic and hydrodynamic parameters of one link (link frame, FLU, [linear; angular]).

    Attributes:
        volume: displaced volume [m^3] (buoyancy rho g V at the centre of buoyancy).
        center_of_buoyancy: (3,) [m] in the link frame.
        added_mass: (6, 6) M_A about the link origin, order [u v w p q r]
            [kg, kg m, kg m^2]; symmetric positive semi-definite (symmetric within :data:`MATRIX_TOLERANCE` of
            its largest entry is averaged to exactly symmetric, with an :class:`AddedMassSymmetrizedWarning`).
        linear_damping: (6,) d_l >= 0 [N s/m, N m s/rad].
        quadratic_damping: (6,) d_q >= 0 [N s^2/m^2, N m s^2/rad^2].
        linear_damping_forward_speed: (6,) d_f >= 0 [N s^2/m^2, N m s^2/(rad m)]: linear damping per m/s of
            forward speed (uuv_simulator's ``linear_damping_forward_speed``, an AUV's lift-like damping).

    Raises:
        ModelCheckError: a wrong shape, a non-finite number, a negative volume or
            damping, an added mass that is not symmetric positive semi-definite.
    """

    volume: float = 0.0
    center_of_buoyancy: np.ndarray = field(default_factory=lambda: np.zeros(3))
    added_mass: np.ndarray = field(default_factory=lambda: np.zeros((6, 6)))
    linear_damping: np.ndarray = field(default_factory=lambda: np.zeros(6))
    quadratic_damping: np.ndarray = field(default_factory=lambda: np.zeros(6))
    linear_damping_forward_speed: np.ndarray = field(default_factory=lambda: np.zeros(6))

    def __post_init__(self) -> None:
        volume = _array(self.volume, (), "volume")
        if volume < 0:
            raise ModelCheckError(f"volume must be >= 0 m^3, got {float(volume):g}")
        object.__setattr__(self, "volume", float(volume))
        object.__setattr__(self, "center_of_buoyancy", _array(self.center_of_buoyancy, (3,), "center_of_buoyancy"))
        added = _array(self.added_mass, (6, 6), "added_mass")
        if np.array_equal(added, added.T):
            check_added_mass(added)
        else:
            added = _array(symmetrized_added_mass(added, "LinkHydrodynamics"), (6, 6), "added_mass")
        object.__setattr__(self, "added_mass", added)
        for name in ("linear_damping", "quadratic_damping", "linear_damping_forward_speed"):
            values = _array(getattr(self, name), (6,), name)
            if np.any(values < 0):
                raise ModelCheckError(
                    f"{name} coefficients must be >= 0 (damping that removes energy), got {values.tolist()}")
            object.__setattr__(self, name, values)

    def damping_wrench(self, nu_r: np.ndarray) -> np.ndarray:
        """Fossen's damping wrench ``-(D_l + u D_f + D_q |nu_r|) nu_r`` (6,) [N, N m] for a relative twist nu_r (6,),
        u = nu_r[0] (uuv_simulator's ``HMFossen::ComputeDampingMatrix``: ``-DLin - vel[0] * DLinForwardSpeed``)."""
        linear = self.linear_damping + nu_r[0] * self.linear_damping_forward_speed
        return -(linear + self.quadratic_damping * np.abs(nu_r)) * nu_r


@dataclass(frozen=True)
class HydroParameters:
    """The fluid and the hydrodynamic parameters of every link that has some.

    Attributes:
        fluid_density: rho [kg/m^3].
        gravity: g [m/s^2] (weight and buoyancy act along -z of the world).
        current: (3,) constant, irrotational ocean current in the world frame (ENU) [m/s].
        links: {link name: LinkHydrodynamics}; links not listed have none.
        source: where the parameters were read (for messages).
    """

    fluid_density: float = SEA_WATER_DENSITY
    gravity: float = GRAVITY
    current: np.ndarray = field(default_factory=lambda: np.zeros(3))
    links: Mapping[str, LinkHydrodynamics] = field(default_factory=dict)
    source: str = "<none>"

    def __post_init__(self) -> None:
        for name in ("fluid_density", "gravity"):
            value = float(_array(getattr(self, name), (), name))
            if value <= 0:
                raise ModelCheckError(f"{name} must be > 0, got {value:g}")
            object.__setattr__(self, name, value)
        object.__setattr__(self, "current", _array(self.current, (3,), "current"))
        for name, link in self.links.items():
            if not isinstance(link, LinkHydrodynamics):
                raise ModelCheckError(f"links[{name!r}] must be a LinkHydrodynamics, got {type(link).__name__}")
        object.__setattr__(self, "links", dict(self.links))

    def with_current(self, current: Iterable[float]) -> HydroParameters:
        """A copy with another ocean current (3,) [m/s], world frame."""
        return replace(self, current=np.asarray(current, dtype=float))

    def check_links(self, valid: Iterable[str]) -> None:
        """Raise NameNotFound (naming the source and the close link names) for a link the model does not have."""
        check_link_names(self.links, valid, self.source)


def check_link_names(names: Iterable[str], valid: Iterable[str] | None, origin: str) -> None:
    """Raise NameNotFound for the first of ``names`` that is not a link of the model (None: not known here).

    Raises:
        NameNotFound: "FILE: unknown link 'hul' (in the hydrodynamic parameters); close names: hull".
    """
    if valid is None:
        return
    valid = list(valid)
    for name in names:
        if name not in valid:
            raise NameNotFound("link (in the hydrodynamic parameters)", str(name), valid, where=origin)


# --------------------------------------------------------------------- checks
def _array(value: object, shape: tuple[int, ...], what: str) -> np.ndarray:
    """value as a read-only float array of ``shape``, or ModelCheckError."""
    try:
        array = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise ModelCheckError(f"{what} must be numbers of shape {shape}, got {value!r}") from None
    if array.shape != shape:
        if array.size == int(np.prod(shape)) and shape:
            array = array.reshape(shape)
        else:
            raise ModelCheckError(f"{what} must have shape {shape} ({int(np.prod(shape))} numbers), got {array.size}")
    if not np.all(np.isfinite(array)):
        raise ModelCheckError(f"{what} has non-finite entries")
    array.setflags(write=False)
    return array


def check_added_mass(matrix: np.ndarray) -> None:
    """Raise ModelCheckError unless ``matrix`` (6, 6) is symmetric positive semi-definite within the tolerance.

    Potential-flow added mass is the Hessian of the fluid's kinetic energy, so it
    is symmetric and semi-definite; anything else makes the mass matrix of the
    plant indefinite (or asymmetric) and the simulation meaningless. Both are checked
    to :data:`MATRIX_TOLERANCE` of the largest entry (at least 1 kg): see :func:`symmetrized_added_mass`.
    """
    scale = max(1.0, float(np.max(np.abs(matrix))))
    asymmetry = np.abs(matrix - matrix.T)
    if np.max(asymmetry) > MATRIX_TOLERANCE * scale:
        i, j = np.unravel_index(int(np.argmax(asymmetry)), matrix.shape)
        raise ModelCheckError(
            f"added_mass must be symmetric: entry ({i},{j}) = {matrix[i, j]:g} but ({j},{i}) = {matrix[j, i]:g} "
            f"(entries may differ by at most {MATRIX_TOLERANCE:g} of the largest, {scale:g})")
    smallest = float(np.min(np.linalg.eigvalsh(0.5 * (matrix + matrix.T))))
    if smallest < -MATRIX_TOLERANCE * scale:
        raise ModelCheckError(f"added_mass must be positive semi-definite; its smallest eigenvalue is {smallest:g}")


def symmetrized_added_mass(matrix: np.ndarray, where: str) -> np.ndarray:
    """An added mass (6, 6) [kg, kg m, kg m^2] checked, and made exactly symmetric, (M + M^T) / 2.

    Published matrices are rounded (uuv_simulator's RexROV: entry (2,5) = 10.774 but (5,2) = 10.775 beside a
    largest entry of 3,659), so an asymmetry within :data:`MATRIX_TOLERANCE` of the largest entry is averaged
    away, with an :class:`AddedMassSymmetrizedWarning` naming ``where`` and the largest difference.

    Args:
        matrix: the added mass as given.
        where: what it is, for the warning (the file and the link).

    Raises:
        ModelCheckError: asymmetric beyond the tolerance, or not positive semi-definite (:func:`check_added_mass`).
    """
    matrix = np.asarray(matrix, dtype=float)
    check_added_mass(matrix)
    asymmetry = np.abs(matrix - matrix.T)
    if np.max(asymmetry) == 0:
        return matrix
    i, j = np.unravel_index(int(np.argmax(asymmetry)), matrix.shape)
    warnings.warn(f"{where}: added_mass is not exactly symmetric (largest difference {asymmetry[i, j]:g} between "
                  f"entries ({i},{j}) and ({j},{i}), within {MATRIX_TOLERANCE:g} of its largest entry); "
                  "using (M + M^T) / 2", AddedMassSymmetrizedWarning, stacklevel=3)
    return 0.5 * (matrix + matrix.T)


def flip_frd_flu(matrix: np.ndarray) -> np.ndarray:
    """A (6, 6) body matrix from SNAME (FRD) to ROS (FLU) axes or back: T M T, T = diag(1,-1,-1,1,-1,-1)."""
    return FRD_FLU_SIGNS[:, None] * matrix * FRD_FLU_SIGNS[None, :] + 0.0  # + 0.0: no -0.0 entries


def hydro_rows(hydro: HydroParameters) -> list[dict[str, object]]:
    """One plain row per link with hydrodynamic parameters, for a table (``uvms info``), in uvms's conventions.

    Returns:
        [{"link": str, "volume": float [m^3], "center_of_buoyancy": [x, y, z] [m] (link frame),
        "added_mass_diagonal": 6 floats [kg, kg, kg, kg m^2, kg m^2, kg m^2], "linear_damping": 6 floats
        [N s/m, N m s/rad], "quadratic_damping": 6 floats [N s^2/m^2, N m s^2/rad^2] and
        "linear_damping_forward_speed": 6 floats [N s^2/m^2, N m s^2/(rad m)] (coefficients >= 0),
        all about the link origin, FLU, order [u v w p q r]}], in the order of ``hydro.links``.
    """
    return [{"link": name, "volume": link.volume, "center_of_buoyancy": link.center_of_buoyancy.tolist(),
             "added_mass_diagonal": np.diag(link.added_mass).tolist(), "linear_damping": link.linear_damping.tolist(),
             "quadratic_damping": link.quadratic_damping.tolist(),
             "linear_damping_forward_speed": link.linear_damping_forward_speed.tolist()}
            for name, link in hydro.links.items()]
