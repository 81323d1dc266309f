"""uuv_simulator's underwater-object plugin (``libuuv_underwater_object_ros_plugin.so``) read as model data: one
``<link>`` entry to a :class:`~uvms.dynamics.hydro.parameters.LinkHydrodynamics` (:func:`link_from_uuv`), the
reader of uuv_simulator registered in :mod:`uvms.dynamics.plugins.readers`; the same keys make uvms's
``hydrodynamics.yaml`` (:func:`load_hydrodynamics_yaml`). The form and its conventions
(uuv_simulator's ``HMFossen``, ``HydrodynamicModel.cc``): :mod:`uvms.dynamics.hydro.hydrodynamics`.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from collections.abc import Iterable, Mapping
from pathlib import Path

import numpy as np

from ...errors import ModelCheckError, ModelParseError
from ...model.resources import read_yaml
from .parameters import (
    GRAVITY,
    SEA_WATER_DENSITY,
    HydroParameters,
    LinkHydrodynamics,
    check_link_names,
    flip_frd_flu,
    symmetrized_added_mass,
)
from .shapes import BOX_KEYS, SHAPE_KEYS, SHAPE_TYPES, shape_coefficients

#: Hydrodynamic model types understood: uuv_simulator's.
MODEL_TYPES = ("fossen",) + SHAPE_TYPES
#: The keys of a ``hydrodynamic_model``.
MODEL_KEYS = ("type", "added_mass", "linear_damping", "quadratic_damping", "linear_damping_forward_speed") + SHAPE_KEYS


def link_from_uuv(
    values: Mapping[str, object], *, fluid_density: float, link_mass: float | None, where: str
) -> LinkHydrodynamics:
    """A LinkHydrodynamics from the values of one uuv_simulator ``<link>`` entry (file conventions).

    Args:
        values: ``volume``, ``center_of_buoyancy``, ``neutrally_buoyant``, ``box`` = {width, length, height} and
            ``hydrodynamic_model`` = {``type``, ``added_mass``, ``linear_damping``,
            ``quadratic_damping``, ``linear_damping_forward_speed``, and the shape's dimensions
            (:data:`MODEL_KEYS`)}, as numbers or whitespace-separated text.
        fluid_density: rho [kg/m^3], for ``neutrally_buoyant``.
        link_mass: the link's mass [kg] in the model, for ``neutrally_buoyant`` (None: unknown).
        where: prefix of error messages.

    Raises:
        ModelCheckError: a missing or invalid value (the message says which and what is valid).
    """
    try:
        model = values.get("hydrodynamic_model") or {}
        if not isinstance(model, Mapping):
            raise ModelCheckError("hydrodynamic_model must hold type, added_mass, linear_damping, quadratic_damping")
        kind = str(model.get("type", "fossen")).strip()
        if kind not in MODEL_TYPES:
            raise ModelCheckError(f"hydrodynamic model type {kind!r} is not supported; valid: {', '.join(MODEL_TYPES)}")
        volume = float(_numbers(values.get("volume", 0.0), "volume", 1)[0])
        if _flag(values.get("neutrally_buoyant", False)):
            if link_mass is None:
                raise ModelCheckError("neutrally_buoyant needs the link's mass, and the model gives it none (no "
                                      "<inertial> mass on this link); give volume [m^3] instead")
            volume = link_mass / fluid_density  # as uuv_simulator's BuoyantObject::SetNeutrallyBuoyant
        added = _numbers(model.get("added_mass", np.zeros(36)), "added_mass", 36).reshape(6, 6).copy()
        linear = _diagonal(model.get("linear_damping", np.zeros(6)), "linear_damping")
        quadratic = _diagonal(model.get("quadratic_damping", np.zeros(6)), "quadratic_damping").copy()
        forward = _diagonal(model.get("linear_damping_forward_speed", np.zeros(6)), "linear_damping_forward_speed")
        if kind in SHAPE_TYPES:  # a fossen model whose diagonal entries the shape then sets, as uuv_simulator's
            box = values.get("box") or None
            if box is not None and not isinstance(box, Mapping):
                raise ModelCheckError(f"box must hold {', '.join(BOX_KEYS)} [m], got {box!r}")
            shape_added, shape_drag = shape_coefficients(kind, model, box, fluid_density, where)
            for index, value in shape_added.items():
                added[index, index] = value
            quadratic[list(shape_drag)] = list(shape_drag.values())
        added = symmetrized_added_mass(added, where)
        for name, derivatives in (("linear_damping", linear), ("quadratic_damping", quadratic),
                                  ("linear_damping_forward_speed", forward)):
            if np.any(derivatives > 0):
                raise ModelCheckError(
                    f"{name} holds positive values {derivatives.tolist()}: uuv_simulator's form takes Fossen's "
                    f"hydrodynamic derivatives (X_u, Y_v, ... <= 0) and a positive one would add energy; "
                    f"negate them")
        return LinkHydrodynamics(
            volume=volume,
            center_of_buoyancy=_numbers(values.get("center_of_buoyancy", np.zeros(3)), "center_of_buoyancy", 3),
            added_mass=flip_frd_flu(added),
            linear_damping=-linear,
            quadratic_damping=-quadratic,
            linear_damping_forward_speed=-forward,
        )
    except ModelCheckError as exc:
        raise ModelCheckError(f"{where}: {exc}") from None


def _numbers(value: object, what: str, count: int | None = None) -> np.ndarray:
    """Numbers from text ("1 2 3") or a (nested) list; ModelCheckError when not ``count`` finite numbers."""
    try:
        if isinstance(value, str):
            array = np.array([float(token) for token in value.split()], dtype=float)
        else:
            array = np.asarray(value, dtype=float).ravel()
    except (TypeError, ValueError):
        raise ModelCheckError(f"{what} is not a list of numbers: {value!r}") from None
    if count is not None and array.size != count:
        raise ModelCheckError(f"{what} holds {array.size} numbers, expected {count}")
    if not np.all(np.isfinite(array)):
        raise ModelCheckError(f"{what} has non-finite entries")
    return array


def _diagonal(value: object, what: str) -> np.ndarray:
    """6 damping values, or the diagonal of 36 (uuv_simulator accepts both) when nothing is off it."""
    array = _numbers(value, what)
    if array.size == 6:
        return array
    if array.size == 36:
        matrix = array.reshape(6, 6)
        if np.any(matrix - np.diag(np.diag(matrix)) != 0):
            raise ModelCheckError(f"{what}: only a diagonal is supported; its 36 values have off-diagonal entries")
        return np.diag(matrix).copy()
    raise ModelCheckError(f"{what} holds {array.size} numbers, expected 6 (or 36 for a diagonal matrix)")


def _flag(value: object) -> bool:
    """uuv_simulator's boolean text: 1/0, true/false."""
    if isinstance(value, bool):
        return value
    text = str(value).strip().lower()
    if text in ("1", "true"):
        return True
    if text in ("0", "false", ""):
        return False
    raise ModelCheckError(f"neutrally_buoyant must be 0/1 or true/false, got {value!r}")



def urdf_link_masses(root: ET.Element) -> dict[str, float]:
    """{link name: mass [kg]} of the URDF links that have an ``<inertial>``."""
    masses = {}
    for link in root.findall("link"):
        mass = link.find("inertial/mass")
        if mass is not None:
            masses[link.get("name", "")] = float(mass.get("value", "0"))
    return masses


def load_hydrodynamics_yaml(
    path: str | os.PathLike,
    link_masses: Mapping[str, float] | None = None,
    link_names: Iterable[str] | None = None,
) -> HydroParameters:
    """Hydrodynamic parameters from a YAML file, in the conventions of the uuv_simulator block.

    README.md ("Hydrodynamics of your vehicle") documents every key, and
    ``models/example_hydrodynamics.yaml`` is a complete file.

    The file::

        fluid_density: 1028.0          # optional [kg/m^3]
        gravity: 9.81                  # optional [m/s^2]
        current: [0.0, 0.0, 0.0]       # optional, world ENU [m/s]
        links:
          base_link:
            volume: 0.0134                       # [m^3]
            neutrally_buoyant: false             # optional: volume = link mass / density
            center_of_buoyancy: [0.0, 0.0, 0.01] # [m], link frame
            hydrodynamic_model:
              type: fossen
              added_mass: [36 numbers or 6 rows of 6]   # SNAME axes
              linear_damping: [6 numbers <= 0]
              quadratic_damping: [6 numbers <= 0]

    Args:
        path: the YAML file.
        link_masses: {link: mass [kg]}, needed only by ``neutrally_buoyant``.
        link_names: the model's links, checked before any value (None: not checked here).

    Raises:
        ModelFileNotFound: the file cannot be read.
        ModelParseError: not YAML, or not of the form above.
        NameNotFound: a link the model does not have (naming the file and the close names).
        ModelCheckError: an invalid value.
    """
    path = Path(path)
    document = read_yaml(path, "hydrodynamics")
    origin = str(path)
    top_keys = ("fluid_density", "gravity", "current", "links")
    if not isinstance(document, Mapping) or not isinstance(document.get("links"), Mapping):
        raise ModelParseError(f"{origin}: expected a mapping with a 'links' mapping (keys: {', '.join(top_keys)})")
    _check_keys(document, top_keys, origin)
    check_link_names((str(name) for name in document["links"]), link_names, origin)
    density = float(_numbers(document.get("fluid_density", SEA_WATER_DENSITY), "fluid_density", 1)[0])
    links = {}
    for name, values in document["links"].items():
        where = f"{origin}: hydrodynamics of link {name!r}"
        if not isinstance(values, Mapping):
            raise ModelParseError(f"{where}: expected a mapping")
        _check_keys(values, ("volume", "neutrally_buoyant", "center_of_buoyancy", "hydrodynamic_model", "box"), where)
        model = values.get("hydrodynamic_model") or {}
        if isinstance(model, Mapping):
            _check_keys(model, MODEL_KEYS, where + " hydrodynamic_model")
        mass = None if link_masses is None else link_masses.get(str(name))
        links[str(name)] = link_from_uuv(values, fluid_density=density, link_mass=mass, where=where)
    try:
        return HydroParameters(
            fluid_density=density,
            gravity=float(_numbers(document.get("gravity", GRAVITY), "gravity", 1)[0]),
            current=_numbers(document.get("current", [0.0, 0.0, 0.0]), "current", 3),
            links=links,
            source=origin,
        )
    except ModelCheckError as exc:
        raise ModelCheckError(f"{origin}: {exc}") from None


def _check_keys(mapping: Mapping, valid: tuple[str, ...], where: str) -> None:
    unknown = sorted(str(key) for key in mapping if key not in valid)
    if unknown:
        raise ModelParseError(f"{where}: unknown key(s) {', '.join(unknown)}; valid: {', '.join(valid)}")
