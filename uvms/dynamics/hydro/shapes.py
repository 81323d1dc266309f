"""The added mass and drag that uuv_simulator computes from a link's shape: its hydrodynamic models ``sphere``,
``cylinder``, ``spheroid`` and ``box``.

Ported from uuv_simulator, ``uuv_gazebo_plugins/uuv_gazebo_plugins/src/HydrodynamicModel.cc`` (classes HMSphere,
HMCylinder, HMSpheroid, HMBox). Each of them is a ``fossen`` model first (``added_mass``, ``linear_damping``,
``quadratic_damping`` of the file, zero when not given) whose diagonal entries below are then replaced by the
shape's, in the file's conventions (SNAME axes; ``quadratic_damping`` holds Fossen's derivatives, <= 0). The
element names are those of the C++ source, inside ``<hydrodynamic_model>``; where the model misses a dimension,
uuv_simulator takes it from the link's bounding box, which uvms reads from the link's ``<box>`` (``<width>``
along x, ``<length>`` along y, ``<height>`` along z, as ``HydrodynamicModel``'s constructor builds it).

sphere (``<radius>`` r, else the smallest extent of the box: a diameter taken as the radius, as the source does)
    added mass 2/3 rho pi r^3 on the three translations (half the displaced mass; MIT Marine Hydrodynamics
    lecture notes, cited by the source), none on the rotations; quadratic drag 1/2 rho Cd pi r^2 with Cd = 0.5
    (a sphere in subcritical flow, Re = 3e5, same notes) on the three translations.
cylinder (``<radius>`` r, ``<length>`` L, ``<axis>`` i, j or k: the axis along which it lies; else the smallest
    extent, the largest extent and the direction of the largest extent of the box)
    along its axis: added mass rho pi r^2 (sic: uuv_simulator leaves out the length here, so this entry is in kg
    for a length in m) and drag 1/2 rho Cd_circ pi r^2; across: added mass rho pi r^2 L and drag
    1/2 rho Cd_length r L (sic: r L, half the projected area 2 r L); rotations about the two transverse axes:
    added mass rho pi r^2 L^3 / 12 (Schjolberg 1994, "Modelling and Control of Underwater-Vehicle Manipulator
    Systems"), about the axis: left as the file gives it. Cd_circ and Cd_length depend on L / (2 r) by the
    table of the source (after http://www.mech.pk.edu.pl/~m52/pdf/fm/R_09.pdf); beyond L / (2 r) = 7 the source
    sets no Cd_circ (an uninitialised value), and uvms takes the table's last, 0.99, with a
    :class:`ShapeCoefficientWarning`.
spheroid (``<radius>`` b, the semi-minor axis, and ``<length>`` a, the semi-major axis along x, as the source's
    eccentricity e = sqrt(1 - (b / a)^2) reads them; else the smallest and largest extents of the box)
    Lamb's added mass of a prolate spheroid (Lamb, "Hydrodynamics", 1932, the moving ellipsoid; in this form
    in Fossen, "Handbook of Marine Craft Hydrodynamics and Motion Control", 2011; the source cites Antonelli,
    "Underwater Robots"):
    with alpha0 = 2 (1 - e^2) / e^3 (ln((1 + e) / (1 - e)) / 2 - e),
    beta0 = 1 / e^2 - (1 - e^2) / (2 e^3) ln((1 + e) / (1 - e)) and m = rho 4/3 pi a b^2:
    surge m alpha0 / (2 - alpha0), sway and heave m beta0 / (2 - beta0), roll 0, pitch and yaw
    m / 5 (b^2 - a^2)^2 (alpha0 - beta0) / (2 (b^2 - a^2) + (b^2 + a^2) (beta0 - alpha0)); no drag.
    uuv_simulator marks this model "still in development, don't use it", and its code differs from these
    formulas in three places that uvms corrects: beta0 is computed as 1/e^2 - (1 - e^2 / (2 e^3)) ln(...) (a
    misplaced parenthesis: negative for slender bodies), pitch and yaw take Fossen's derivative with its minus
    sign (a negative added mass), and m is the link's mass (equal to the displaced mass for a neutrally
    buoyant spheroid).
box (``<length>`` along x, ``<width>`` along y, ``<height>`` along z, all three required; ``<cd>``, default 1)
    quadratic drag 1/2 rho Cd times the area facing each translation (width height, length height,
    width length); no added mass. (The versions of uuv_simulator whose HMFossen fills its damping matrices in
    its constructor have HMBox, and HMSphere in some of them, write the drag to a vector the damping no longer
    reads, so Gazebo applies none; uvms applies it, as the models intend and the earlier versions did.)

The density is the plugin's ``<fluid_density>`` (uuv_simulator computes these coefficients before it sets
that density, so Gazebo uses its default 1028 kg/m^3 for them; the same for sea water).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping

import numpy as np

from ...errors import ModelCheckError, ShapeCoefficientWarning

#: The shape models, by their ``<type>``.
SHAPE_TYPES = ("sphere", "cylinder", "spheroid", "box")
#: The elements they read inside ``<hydrodynamic_model>``, and those of the link's ``<box>``.
SHAPE_KEYS = ("radius", "length", "width", "height", "axis", "cd")
BOX_KEYS = ("width", "length", "height")
#: Drag coefficients of a cylinder (HMCylinder): (largest L / (2 r), Cd) along the axis and across it.
CD_CIRCULAR = ((1.0, 0.91), (2.0, 0.85), (4.0, 0.87), (7.0, 0.99))
CD_LENGTH = ((1.0, 0.63), (2.0, 0.68), (5.0, 0.74), (10.0, 0.82), (math.inf, 0.98))
#: Drag coefficient of a sphere in subcritical flow (HMSphere).
CD_SPHERE = 0.5


def shape_coefficients(kind: str, model: Mapping[str, object], box: Mapping[str, object] | None,
                       fluid_density: float, where: str) -> tuple[dict[int, float], dict[int, float]]:
    """The diagonal entries a shape model sets, in the file's conventions (SNAME, [u v w p q r]).

    Args:
        kind: one of :data:`SHAPE_TYPES`.
        model: the ``<hydrodynamic_model>`` values (numbers or text).
        box: the link's ``<box>`` values (width, length, height [m]) or None.
        fluid_density: rho [kg/m^3].
        where: prefix of messages.

    Returns:
        ({index: added-mass entry [kg, kg m^2]}, {index: quadratic-damping derivative <= 0 [N s^2/m^2]}).

    Raises:
        ModelCheckError: a missing or non-positive dimension, an axis other than i, j, k.
    """
    if kind == "box":
        return _box(model, fluid_density)
    extents = _extents(box)
    radius = _dimension(model, "radius", None if extents is None else min(extents))
    if kind == "sphere":
        added = 2.0 / 3.0 * fluid_density * math.pi * radius ** 3
        drag = -0.5 * fluid_density * CD_SPHERE * math.pi * radius ** 2
        return dict.fromkeys(range(3), added), dict.fromkeys(range(3), drag)
    length = _dimension(model, "length", None if extents is None else max(extents))
    if kind == "spheroid":
        return _spheroid(radius, length, fluid_density), {}
    return _cylinder(radius, length, _axis(model, extents), fluid_density, where)


def _cylinder(radius: float, length: float, axis: int, rho: float, where: str) -> tuple[dict, dict]:
    ratio = length / (2.0 * radius)
    if ratio > CD_CIRCULAR[-1][0]:
        warnings.warn(f"{where}: the cylinder's length / diameter {ratio:.3g} is beyond uuv_simulator's table of "
                      f"its axial drag coefficient (<= {CD_CIRCULAR[-1][0]:g}, where it leaves the coefficient "
                      f"undefined); using the table's last value {CD_CIRCULAR[-1][1]:g}", ShapeCoefficientWarning,
                      stacklevel=4)
    cd_circular = next((cd for bound, cd in CD_CIRCULAR if ratio <= bound), CD_CIRCULAR[-1][1])
    cd_length = next(cd for bound, cd in CD_LENGTH if ratio <= bound)
    across = [i for i in range(3) if i != axis]
    added = {axis: rho * math.pi * radius ** 2}
    added |= dict.fromkeys(across, rho * math.pi * radius ** 2 * length)
    added |= dict.fromkeys((3 + i for i in across), rho * math.pi * radius ** 2 * length ** 3 / 12.0)
    drag = {axis: -0.5 * cd_circular * math.pi * radius ** 2 * rho}
    drag |= dict.fromkeys(across, -0.5 * cd_length * radius * length * rho)
    return added, drag


def _spheroid(radius: float, length: float, rho: float) -> dict[int, float]:
    if not radius < length:
        raise ModelCheckError(f"a spheroid needs radius (semi-minor axis) < length (semi-major axis), got "
                              f"radius {radius:g} m and length {length:g} m (a sphere is type sphere)")
    a, b = length, radius
    e = math.sqrt(1.0 - (b / a) ** 2)
    log = math.log((1.0 + e) / (1.0 - e))
    alpha = 2.0 * (1.0 - e ** 2) / e ** 3 * (0.5 * log - e)
    beta = 1.0 / e ** 2 - (1.0 - e ** 2) / (2.0 * e ** 3) * log
    mass = rho * 4.0 / 3.0 * math.pi * a * b ** 2
    rotation = mass / 5.0 * (b ** 2 - a ** 2) ** 2 * (alpha - beta) / (
        2.0 * (b ** 2 - a ** 2) + (b ** 2 + a ** 2) * (beta - alpha))
    return {0: mass * alpha / (2.0 - alpha), 1: mass * beta / (2.0 - beta), 2: mass * beta / (2.0 - beta),
            3: 0.0, 4: rotation, 5: rotation}


def _box(model: Mapping[str, object], rho: float) -> tuple[dict, dict]:
    missing = [key for key in ("length", "width", "height") if key not in model]
    if missing:
        raise ModelCheckError(f"the box model needs <length>, <width> and <height> [m] in <hydrodynamic_model>; "
                              f"missing: {', '.join(missing)}")
    length, width, height = (_dimension(model, key, None) for key in ("length", "width", "height"))
    cd = _number(model.get("cd", 1.0), "cd")
    if cd < 0:
        raise ModelCheckError(f"the box's drag coefficient cd must be >= 0, got {cd:g}")
    areas = (width * height, length * height, width * length)
    return {}, {i: -0.5 * cd * area * rho for i, area in enumerate(areas)}


def _axis(model: Mapping[str, object], extents: tuple[float, float, float] | None) -> int:
    """0, 1, 2 for the cylinder's ``<axis>`` i, j, k; else the direction of the box's largest extent."""
    if "axis" in model:
        text = str(model["axis"]).strip()
        if text not in ("i", "j", "k"):
            raise ModelCheckError(f"the cylinder's axis must be i, j or k (x, y or z of the link), got {text!r}")
        return "ijk".index(text)
    if extents is None:
        raise ModelCheckError("the cylinder has no <axis> (i, j or k) and the link no <box> to take it from (the "
                              "direction of its largest extent); give <axis>")
    return int(np.argmax(extents))  # the first of equal extents, as the source's x, y, z order


def _extents(box: Mapping[str, object] | None) -> tuple[float, float, float] | None:
    """(x, y, z) extents [m] of the link's ``<box>``: width, length, height; None without a box."""
    if not box:
        return None
    missing = [key for key in BOX_KEYS if key not in box]
    if missing:
        raise ModelCheckError(f"the link's <box> misses {', '.join(missing)} (it takes width, length, height [m])")
    extents = tuple(_number(box[key], f"box {key}") for key in BOX_KEYS)
    if min(extents) <= 0:
        raise ModelCheckError(f"the link's <box> dimensions must be > 0 m, got {list(extents)}")
    return extents


def _dimension(model: Mapping[str, object], key: str, fallback: float | None) -> float:
    """A dimension [m] > 0 from ``<key>``, else from the link's box (``fallback``)."""
    if key not in model:
        if fallback is None:
            raise ModelCheckError(f"the shape needs <{key}> [m] in <hydrodynamic_model> (or a <box> of the link "
                                  f"to take it from; uuv_simulator would measure Gazebo's bounding box, which uvms "
                                  f"does not)")
        return fallback
    value = _number(model[key], key)
    if value <= 0:
        raise ModelCheckError(f"<{key}> must be > 0 m, got {value:g}")
    return value


def _number(value: object, what: str) -> float:
    try:
        number = float(str(value).strip())
    except ValueError:
        raise ModelCheckError(f"<{what}> must be a number, got {value!r}") from None
    if not math.isfinite(number):
        raise ModelCheckError(f"<{what}> must be a finite number, got {value!r}")
    return number
