"""The readers of simulator plugins, one module per simulator, registered by simulator: a model's thrusters and
hydrodynamics from its ``<gazebo>`` plugin blocks.

* uuv_simulator: :func:`~.sources.read_uuv_thruster`, the underwater-object block
  (:func:`~.uuv.link_from_uuv`);
* Gazebo Sim: :func:`~.gz_sim.read_gz_thruster`, :func:`~.gz_sim.gz_hydrodynamics_fields`,
  :func:`~.gz_sim.gz_buoyancy_density`;
* HippoCampus: :func:`~.hippo.read_hippo_thruster`, :func:`~.hippo.hippo_hydrodynamics_fields`,
  :func:`~.hippo.hippo_buoyancy_fields`.

Which ``<plugin>`` is of which kind: :mod:`uvms.model.plugins`. A new simulator is one module of readers and one
entry in each of :data:`THRUSTER_READERS`, :data:`HYDRO_BLOCKS` (and :data:`DENSITIES` when its plugins give the
fluid density) beside a :class:`~uvms.model.plugins.PluginKind`.

Hydrodynamics of several blocks are merged per link: each block gives some fields of a link (a hippo buoyancy its
volume, a hippo hydrodynamics its damping); a field given twice is refused. A block naming a link the model does not
have is skipped with a :class:`~uvms.errors.SkippedLinkWarning`, as Gazebo does (DAVE's RexROV names
``oberon7/base``); ``--strict`` on a uvms command (in Python: ``warnings.simplefilter("error",
SkippedLinkWarning)``) refuses it.
"""

from __future__ import annotations

import difflib
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass

import numpy as np

from ...errors import ModelCheckError, SkippedLinkWarning
from ...model.plugins import GZ, HIPPO, UUV, plugins_of
from ..hydro.parameters import SEA_WATER_DENSITY, HydroParameters, LinkHydrodynamics
from ..hydro.uuv import link_from_uuv, urdf_link_masses
from ..thrusters.sources import PluginThruster, _float, read_uuv_thruster
from .gz_sim import gz_buoyancy_density, gz_hydrodynamics_fields, read_gz_thruster
from .hippo import hippo_buoyancy_fields, hippo_hydrodynamics_fields, read_hippo_thruster

#: simulator -> reader(plugin, robot root, thruster name, where) -> PluginThruster.
THRUSTER_READERS: dict[str, Callable[[ET.Element, ET.Element, str, str], PluginThruster]] = {
    UUV: read_uuv_thruster, GZ: read_gz_thruster, HIPPO: read_hippo_thruster}


@dataclass(frozen=True)
class Context:
    """What a hydrodynamic block's reader may need besides its element: the model and the fluid."""

    root: ET.Element
    origin: str
    density: float
    moving: frozenset[str] = frozenset()


@dataclass(frozen=True)
class Block:
    """One link's hydrodynamic data in a plugin: the link, where it is (messages), and its fields when read
    (lazily: a block of a link the model does not have is skipped unread, as Gazebo skips it)."""

    link: str
    where: str
    read: Callable[[], dict[str, object]]


def read_thruster_plugins(root: ET.Element, origin: str) -> list[PluginThruster]:
    """The thruster plugins of a URDF ``<robot>`` of every simulator uvms reads, in file order (empty: none).

    Raises:
        ModelCheckError: a plugin's invalid data (the message names the plugin).
    """
    thrusters = []
    for index, (kind, plugin) in enumerate(plugins_of(root, "thruster")):
        name = kind.label(plugin, index)
        thrusters.append(THRUSTER_READERS[kind.simulator](
            plugin, root, name, f"{origin}: {kind.simulator} thruster plugin {name!r}"))
    return thrusters


# ------------------------------------------------------------------ hydrodynamics
def _uuv_blocks(plugin: ET.Element, context: Context) -> Iterator[Block]:
    masses = urdf_link_masses(context.root)
    for element in plugin.findall("link"):
        name = element.get("name", "")
        values: dict[str, object] = {child.tag: (child.text or "") for child in element}
        for tag in ("hydrodynamic_model", "box"):
            nested = element.find(tag)
            if nested is not None:
                values[tag] = {child.tag: (child.text or "") for child in nested}
        where = f"{context.origin}: hydrodynamics of link {name!r}"
        yield Block(name, where, lambda v=values, n=name, w=where: link_fields(link_from_uuv(
            v, fluid_density=context.density, link_mass=masses.get(n), where=w)))


def _gz_blocks(plugin: ET.Element, context: Context) -> Iterator[Block]:
    name = (plugin.findtext("link_name") or "").strip()
    where = f"{context.origin}: Gazebo Sim Hydrodynamics plugin of link {name!r}"
    if not name:
        raise ModelCheckError(f"{where}: <link_name> is missing; it names the link the forces act on")
    yield Block(name, where, lambda: gz_hydrodynamics_fields(plugin, where))


def _hippo_blocks(plugin: ET.Element, context: Context) -> Iterator[Block]:
    for element in plugin.findall("hydrodynamics"):
        name = (element.findtext("link") or "").strip()
        where = f"{context.origin}: HippoCampus hydrodynamics of link {name!r}"
        yield Block(name, where, lambda e=element, w=where: hippo_hydrodynamics_fields(e, w))


def _hippo_buoyancy(plugin: ET.Element, context: Context) -> Iterator[Block]:
    for element in plugin.findall("buoyancy"):
        name = (element.findtext("link_name") or "base_link").strip()
        where = f"{context.origin}: HippoCampus buoyancy of link {name!r}"
        yield Block(name, where, lambda e=element, n=name, w=where: hippo_buoyancy_fields(
            e, lumped_mass(context.root, n, context.moving), context.density, w))


#: (simulator, role) -> blocks(plugin, context): the links a plugin gives hydrodynamic data for.
HYDRO_BLOCKS: dict[tuple[str, str], Callable[[ET.Element, Context], Iterable[Block]]] = {
    (UUV, "hydrodynamics"): _uuv_blocks, (GZ, "hydrodynamics"): _gz_blocks,
    (HIPPO, "hydrodynamics"): _hippo_blocks, (HIPPO, "buoyancy"): _hippo_buoyancy}
#: (simulator, role) -> density(plugin, where): the fluid density [kg/m^3] a plugin gives, or None.
DENSITIES: dict[tuple[str, str], Callable[[ET.Element, str], float | None]] = {
    (UUV, "hydrodynamics"): lambda plugin, where: _float(plugin.findtext("fluid_density", str(SEA_WATER_DENSITY)),
                                                         "fluid_density", where),
    (GZ, "buoyancy"): gz_buoyancy_density}


def read_hydro_plugins(root: ET.Element, origin: str, link_names: Iterable[str] | None = None,
                       moving: Iterable[str] = ()) -> HydroParameters | None:
    """The hydrodynamic parameters of a URDF's plugin blocks of every simulator uvms reads (the module docstring).

    Args:
        root: the URDF ``<robot>``; origin: the model, for messages; link_names: the model's links (None: not
            checked here); moving: the joints that move in the model's file (fixed in ``root`` once frozen).

    Returns:
        The parameters, or None when the URDF has no hydrodynamic or buoyancy plugin uvms reads.

    Raises:
        ModelCheckError: an invalid value, a field of a link given twice, plugins with different fluid densities
            or currents.

    Warns:
        SkippedLinkWarning: per block naming a link the model does not have (skipped).
    """
    plugins = [(kind, plugin) for role in ("hydrodynamics", "buoyancy") for kind, plugin in plugins_of(root, role)]
    if not plugins:
        return None
    where = {kind: f"{origin}: {kind.simulator} {kind.role} plugin" for kind, _ in plugins}
    densities = {d for kind, plugin in plugins if (kind.simulator, kind.role) in DENSITIES
                 and (d := DENSITIES[kind.simulator, kind.role](plugin, where[kind])) is not None}
    if len(densities) > 1:
        raise ModelCheckError(f"{origin}: the plugins give different fluid densities {sorted(densities)} kg/m^3")
    context = Context(root, origin, densities.pop() if densities else SEA_WATER_DENSITY, frozenset(moving))
    valid = None if link_names is None else list(link_names)
    fields: dict[str, dict[str, object]] = {}
    given_by: dict[tuple[str, str], str] = {}
    currents = []
    for kind, plugin in plugins:
        for block in HYDRO_BLOCKS.get((kind.simulator, kind.role), lambda p, c: ())(plugin, context):
            if valid is not None and block.link not in valid:
                close = difflib.get_close_matches(block.link, valid, n=5, cutoff=0.4)
                warnings.warn(f"{block.where}: the model has no link {block.link!r}"
                              f"{'; close names: ' + ', '.join(close) if close else ''}; the block is skipped, as "
                              f"Gazebo skips it (--strict refuses it)", SkippedLinkWarning, stacklevel=4)
                continue
            for key, value in block.read().items():
                if key == "current":
                    currents.append(np.asarray(value, dtype=float))
                    continue
                if (block.link, key) in given_by:
                    raise ModelCheckError(f"{block.where}: the link's {key} is given twice (also by "
                                          f"{given_by[block.link, key]})")
                given_by[block.link, key] = block.where
                fields.setdefault(block.link, {})[key] = value
    if any(not np.allclose(current, currents[0], rtol=0, atol=0) for current in currents):
        raise ModelCheckError(f"{origin}: the plugins give different currents {[c.tolist() for c in currents]} m/s")
    try:
        links = {name: LinkHydrodynamics(**values) for name, values in fields.items()}
        return HydroParameters(fluid_density=context.density, links=links, source=origin,
                               current=currents[0] if currents else np.zeros(3))
    except ModelCheckError as exc:
        raise ModelCheckError(f"{origin}: {exc}") from None


def link_fields(link: LinkHydrodynamics) -> dict[str, object]:
    """Every field of a LinkHydrodynamics, as the keywords that build it."""
    return {name: getattr(link, name) for name in LinkHydrodynamics.__dataclass_fields__}


def lumped_mass(root: ET.Element, link: str, moving: Iterable[str] = ()) -> float | None:
    """A link's mass [kg] as Gazebo sees it: its own and that of the links below it through fixed joints, which
    the URDF-to-SDF conversion lumps into it (unless ``<preserveFixedJoint>`` or ``<disableFixedJointLumping>``
    keeps a joint, or the joint is one of ``moving``: a joint of the file that uvms froze); None when none of them
    has an ``<inertial>`` mass."""
    kept = {gazebo.get("reference") for gazebo in root.findall("gazebo")
            if any((gazebo.findtext(tag) or "").strip().lower() in ("true", "1")
                   for tag in ("preserveFixedJoint", "disableFixedJointLumping"))} | set(moving)
    own = {}
    for element in root.findall("link"):
        mass = element.find("inertial/mass")
        if mass is not None:
            own[element.get("name", "")] = float(mass.get("value", "0"))
    fixed: dict[str, list[str]] = {}
    for joint in root.findall("joint"):
        if joint.get("type") == "fixed" and joint.get("name") not in kept:
            fixed.setdefault(joint.find("parent").get("link"), []).append(joint.find("child").get("link"))
    found, total, stack, seen = False, 0.0, [link], set()
    while stack:
        name = stack.pop()
        if name in seen:
            continue
        seen.add(name)
        if name in own:
            found, total = True, total + own[name]
        stack.extend(fixed.get(name, []))
    return total if found else None
