"""Checks of a URDF document before Pinocchio sees it.

Pinocchio accepts many inputs that give silently wrong kinematics or dynamics
(a non-unit axis, a NaN in an origin, a planar joint whose axis it ignores, a
negative mass, a cylinder of negative length). Each check here raises :class:`uvms.errors.ModelCheckError` naming the
element and saying what is valid.
"""

from __future__ import annotations

import warnings
import xml.etree.ElementTree as ET
from dataclasses import dataclass, replace

import numpy as np

from ..errors import ModelCheckError, ModelParseError, PointMassWarning

#: Attributes holding numbers in URDF, and how many each holds (None: any count).
NUMERIC_ATTRIBUTES: dict[str, int | None] = {
    "xyz": 3, "rpy": 3, "value": 1,
    "ixx": 1, "ixy": 1, "ixz": 1, "iyy": 1, "iyz": 1, "izz": 1,
    "lower": 1, "upper": 1, "effort": 1, "velocity": 1,
    "damping": 1, "friction": 1, "radius": 1, "length": 1, "size": 3, "scale": 3,
    "multiplier": 1, "offset": 1,
}

#: Largest magnitude of a number in a model, in SI units (m, kg, kg m^2); joint limits may be larger
#: (some URDFs write +-1e16 for "unbounded"). Beyond this, products overflow or lose every digit.
MAX_MAGNITUDE = 1e9
MAX_LIMIT_MAGNITUDE = 1e20
LIMIT_ATTRIBUTES = ("lower", "upper", "effort", "velocity")

#: Sizes no UVMS reaches, refused before Pinocchio sees the file: Pinocchio's parser recurses once per link
#: (a 10,000-link chain overflows its stack) and its Data grows with the cube of the degrees of freedom
#: (about 150 MiB at 100, 640 MiB at 200, 4.5 GiB at 400).
MAX_URDF_BYTES = 32 << 20
MAX_ELEMENTS = 200_000
MAX_LINKS = 1_000
MAX_DEGREES_OF_FREEDOM = 100

#: Joint types of URDF and the degrees of freedom each adds.
JOINT_DEGREES_OF_FREEDOM = {"fixed": 0, "revolute": 1, "continuous": 1, "prismatic": 1, "planar": 3, "floating": 6}

#: Relative tolerance on the norm of a joint axis.
AXIS_NORM_TOLERANCE = 1e-6

BASE_JOINT_TYPES = ("floating", "planar")


@dataclass(frozen=True)
class TreeSummary:
    """The root of a URDF tree and the joint that carries the vehicle, if any."""

    root_link: str
    base_type: str  # "floating", "planar" or "fixed"
    base_joint: str | None
    root_mass: float = 0.0  # [kg] of the root link's <inertial> (0 when it has none)
    point_masses: tuple[str, ...] = ()  # links with a mass and an all-zero inertia (uvms.model.point_masses)


def parse_urdf(xml: str, origin: str) -> ET.Element:
    """Parse URDF text into an element tree whose root is ``<robot>``.

    Raises:
        ModelCheckError: larger than ``MAX_URDF_BYTES``.
        ModelParseError: not well-formed XML, or the root element is not ``<robot>``.
    """
    if len(xml) > MAX_URDF_BYTES:
        raise ModelCheckError(f"{origin}: the URDF holds {len(xml) / 2**20:.0f} MiB of text; at most "
                              f"{MAX_URDF_BYTES >> 20} MiB are accepted (no UVMS model is that large)")
    try:
        root = ET.fromstring(xml)
    except ET.ParseError as exc:
        raise ModelParseError(f"{origin}: malformed XML ({exc})") from None
    if root.tag != "robot":
        raise ModelParseError(f"{origin}: the root element is <{root.tag}>, a URDF needs <robot>")
    return root


def parse_numbers(element: ET.Element, attribute: str, origin: str) -> np.ndarray:
    """The finite numbers of one attribute.

    Raises:
        ModelCheckError: not numbers, the wrong count, NaN or infinite.
    """
    text = element.get(attribute, "")
    where = f"{origin}: <{element.tag} {attribute}={text!r}>{describe_owner(element)}"
    try:
        values = np.array([float(token) for token in text.split()], dtype=float)
    except ValueError:
        raise ModelCheckError(f"{where} is not a list of numbers") from None
    expected = NUMERIC_ATTRIBUTES.get(attribute)
    if expected is not None and values.size != expected:
        raise ModelCheckError(f"{where} holds {values.size} numbers, expected {expected}")
    if not np.all(np.isfinite(values)):
        raise ModelCheckError(f"{where} is not finite; every number of a model must be finite")
    bound = MAX_LIMIT_MAGNITUDE if attribute in LIMIT_ATTRIBUTES else MAX_MAGNITUDE
    if values.size and np.max(np.abs(values)) > bound:
        raise ModelCheckError(f"{where} exceeds {bound:g} in magnitude; no UVMS has such a value (SI units)")
    return values


def describe_owner(element: ET.Element) -> str:
    """A ' in link/joint NAME' suffix, filled in by :func:`check_urdf` through a parent map."""
    owner = element.get("_owner")
    return f" in {owner}" if owner else ""


def tag_owners(robot: ET.Element) -> None:
    """Annotate every element with the link or joint it belongs to, for error messages."""
    for top in robot:
        if top.tag in ("link", "joint"):
            label = f"{top.tag} {top.get('name')!r}"
            for element in top.iter():
                element.set("_owner", label)


def check_numbers(robot: ET.Element, origin: str) -> None:
    """Every numeric attribute of the document is a finite number of the right count."""
    for element in robot.iter():
        if element.tag in ("robot", "material", "color", "texture"):
            continue
        for attribute in NUMERIC_ATTRIBUTES:
            if attribute in element.attrib and not (element.tag == "mesh" and attribute == "size"):
                parse_numbers(element, attribute, origin)


def check_joint_axes(robot: ET.Element, origin: str) -> None:
    """Joint axes are unit vectors; a planar joint's axis (its plane normal) is z.

    Pinocchio normalizes nothing and ignores the axis of a planar joint, so a
    wrong axis would give wrong kinematics without a word.
    """
    for joint in robot.findall("joint"):
        axis = joint.find("axis")
        if axis is None or joint.get("type") in ("fixed", "floating"):
            continue
        values = parse_numbers(axis, "xyz", origin)
        norm = float(np.linalg.norm(values))
        name = joint.get("name")
        if norm == 0.0:
            raise ModelCheckError(f"{origin}: joint {name!r} has a zero axis; give a unit vector such as '0 0 1'")
        if abs(norm - 1.0) > AXIS_NORM_TOLERANCE:
            raise ModelCheckError(
                f"{origin}: joint {name!r} axis {axis.get('xyz')!r} has norm {norm:.6g}; "
                f"joint axes must be unit vectors (normalize it)"
            )
        if joint.get("type") == "planar" and not np.allclose(values, [0.0, 0.0, 1.0], atol=1e-9):
            raise ModelCheckError(
                f"{origin}: planar joint {name!r} has axis {axis.get('xyz')!r}; only the x-y plane "
                f"(axis '0 0 1') is supported — rotate the joint origin instead"
            )


def check_inertias(robot: ET.Element, origin: str) -> tuple[str, ...]:
    """Masses are positive and inertia matrices positive definite.

    An ``<inertial>`` with zero mass and an all-zero inertia is the common URDF
    idiom for a massless link and is accepted as such. A positive mass with an all-zero
    inertia (uuv_simulator's thruster links: 0.001 kg) is a point mass: accepted with one
    :class:`~uvms.errors.PointMassWarning` naming the links (the loader then refuses
    a model whose mass matrix they make singular).

    Returns:
        The names of the point-mass links.
    """
    point_masses = []
    for link in robot.findall("link"):
        inertial = link.find("inertial")
        if inertial is None:
            continue
        name = link.get("name")
        mass_element = inertial.find("mass")
        inertia_element = inertial.find("inertia")
        if mass_element is None or inertia_element is None:
            raise ModelCheckError(f"{origin}: link {name!r} has an <inertial> without <mass> and <inertia>")
        mass = float(parse_numbers(mass_element, "value", origin)[0])
        inertia = inertia_matrix(inertia_element, origin)
        if mass == 0.0 and not inertia.any():
            continue  # massless link
        if mass <= 0.0:
            raise ModelCheckError(f"{origin}: link {name!r} has mass {mass:g} kg; a mass must be positive")
        if not inertia.any():
            point_masses.append(name)
            continue
        smallest = float(np.linalg.eigvalsh(inertia)[0])
        if smallest <= 0.0:
            raise ModelCheckError(
                f"{origin}: link {name!r} inertia is not positive definite (smallest eigenvalue "
                f"{smallest:.3g} kg m^2); principal moments must be positive"
            )
    if point_masses:
        warnings.warn(f"{origin}: link(s) {', '.join(point_masses)} have a mass but an all-zero inertia; taken as "
                      "point masses (as Gazebo does)", PointMassWarning, stacklevel=4)
    return tuple(point_masses)


#: Sizes of URDF geometry that must be positive [m]: a negative or zero length, radius or box side has no
#: shape (and is how a negative link length given as a xacro arg usually shows).
GEOMETRY_SIZES = {"box": ("size",), "cylinder": ("radius", "length"), "sphere": ("radius",),
                  "capsule": ("radius", "length")}


def check_geometry(robot: ET.Element, origin: str) -> None:
    """Box sides, cylinder/sphere/capsule radii and lengths of every visual and collision are > 0; mesh scales are not
    0.

    Raises:
        ModelCheckError: naming the link, the element and the value.
    """
    for link in robot.findall("link"):
        for kind in ("visual", "collision"):
            for geometry in link.findall(f"{kind}/geometry"):
                for shape in geometry:
                    for attribute in GEOMETRY_SIZES.get(shape.tag, ()):
                        if attribute not in shape.attrib:
                            continue
                        values = parse_numbers(shape, attribute, origin)
                        if np.any(values <= 0):
                            raise ModelCheckError(
                                f"{origin}: link {link.get('name')!r} {kind} <{shape.tag} {attribute}="
                                f"{shape.get(attribute)!r}>: a geometry size must be > 0 m (a negative or zero "
                                f"length, radius or side)")
                    if shape.tag == "mesh" and "scale" in shape.attrib and np.any(
                            parse_numbers(shape, "scale", origin) == 0):
                        raise ModelCheckError(f"{origin}: link {link.get('name')!r} {kind} <mesh scale="
                                              f"{shape.get('scale')!r}>: a scale of 0 flattens the mesh; give non-zero "
                                              "factors")


def inertia_matrix(element: ET.Element, origin: str) -> np.ndarray:
    """The symmetric 3x3 inertia matrix [kg m^2] of an ``<inertia>`` element."""
    get = {key: float(parse_numbers(element, key, origin)[0]) if key in element.attrib else 0.0
           for key in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
    return np.array([
        [get["ixx"], get["ixy"], get["ixz"]],
        [get["ixy"], get["iyy"], get["iyz"]],
        [get["ixz"], get["iyz"], get["izz"]],
    ])


def summarize_tree(robot: ET.Element, origin: str) -> TreeSummary:
    """Find the root link and whether a floating/planar joint carries the vehicle.

    Raises:
        ModelCheckError: no links, two roots, a link with two parents, an unknown
            link in a joint, or a floating/planar joint that is not the only
            joint at the root.
    """
    links = [link.get("name") for link in robot.findall("link")]
    if not links:
        raise ModelCheckError(f"{origin}: the model has no <link>")
    parents: dict[str, str] = {}
    children_of: dict[str, list[ET.Element]] = {name: [] for name in links}
    for joint in robot.findall("joint"):
        name = joint.get("name")
        parent, child = joint.find("parent"), joint.find("child")
        if parent is None or child is None:
            raise ModelCheckError(f"{origin}: joint {name!r} needs a <parent link=...> and a <child link=...>")
        parent_link, child_link = parent.get("link"), child.get("link")
        for link in (parent_link, child_link):
            if link not in children_of:
                raise ModelCheckError(f"{origin}: joint {name!r} names link {link!r}, which is not defined")
        if child_link in parents:
            raise ModelCheckError(
                f"{origin}: link {child_link!r} is the child of two joints ({parents[child_link]!r} and "
                f"{name!r}); a URDF must be a tree"
            )
        parents[child_link] = name
        children_of[parent_link].append(joint)
    roots = [name for name in links if name not in parents]
    if len(roots) > 1:
        raise ModelCheckError(f"{origin}: the link tree has {len(roots)} roots ({', '.join(roots)}); a URDF must "
                              "have exactly one root link")
    below = links_below(roots[0], children_of) if roots else set()
    if len(below) != len(links):  # each link has one parent: the ones not below the root hang in a cycle
        start = next(name for name in links if name not in below)
        raise ModelCheckError(f"{origin}: the joints form a cycle ({parent_cycle(start, parents, robot)}); a URDF "
                              "must be a tree with exactly one root link")
    root = roots[0]
    root_mass = link_mass(robot.findall("link")[links.index(root)], origin)
    for joint in robot.findall("joint"):
        kind = joint.get("type")
        if kind in BASE_JOINT_TYPES and joint.find("parent").get("link") != root:
            raise ModelCheckError(
                f"{origin}: {kind} joint {joint.get('name')!r} is not at the root link {root!r}; "
                f"floating and planar joints can only carry the vehicle"
            )
    base_joints = [j for j in children_of[root] if j.get("type") in BASE_JOINT_TYPES]
    if not base_joints:
        return TreeSummary(root_link=root, base_type="fixed", base_joint=None, root_mass=root_mass)
    if len(children_of[root]) > 1:
        raise ModelCheckError(
            f"{origin}: the root link {root!r} has a {base_joints[0].get('type')} joint and other joints; "
            f"the vehicle joint must be the only joint at the root"
        )
    return TreeSummary(root_link=root, base_type=base_joints[0].get("type"), base_joint=base_joints[0].get("name"),
                       root_mass=root_mass)


def links_below(root: str, children_of: dict[str, list[ET.Element]]) -> set[str]:
    """The root and every link below it (iterative: a chain may be long, and a cycle ends the walk)."""
    below, frontier = {root}, [root]
    while frontier:
        for joint in children_of[frontier.pop()]:
            child = joint.find("child").get("link")
            if child not in below:
                below.add(child)
                frontier.append(child)
    return below


def parent_cycle(start: str, parents: dict[str, str], robot: ET.Element) -> str:
    """The cycle reached by walking up the parent joints from ``start``, as ``"a -> b -> a"`` (links, each the
    parent of the next).

    Args:
        parents: {child link: the joint above it}; every link on the walk has one (else it would be a root).
    """
    parent_link = {joint.get("name"): joint.find("parent").get("link") for joint in robot.findall("joint")}
    walk, link = [], start
    while link not in walk:
        walk.append(link)
        link = parent_link[parents[link]]
    return " -> ".join([link, *reversed(walk[walk.index(link):])])


def link_mass(link: ET.Element, origin: str) -> float:
    """Mass [kg] of a link's ``<inertial>`` (0.0 when it has none)."""
    mass = link.find("inertial/mass")
    return 0.0 if mass is None else float(parse_numbers(mass, "value", origin)[0])


def check_size(robot: ET.Element, origin: str) -> None:
    """Element, link and degree-of-freedom counts within what any UVMS needs (see ``MAX_*``)."""
    elements = sum(1 for _ in robot.iter())
    if elements > MAX_ELEMENTS:
        raise ModelCheckError(f"{origin}: the URDF has {elements} XML elements; at most {MAX_ELEMENTS} are accepted")
    links = len(robot.findall("link"))
    if links > MAX_LINKS:
        raise ModelCheckError(f"{origin}: the model has {links} links; at most {MAX_LINKS} are accepted "
                              "(no UVMS has more, and Pinocchio's parser recurses once per link)")
    dof = sum(JOINT_DEGREES_OF_FREEDOM.get(joint.get("type"), 0) for joint in robot.findall("joint"))
    if dof > MAX_DEGREES_OF_FREEDOM:
        raise ModelCheckError(f"{origin}: the model has {dof} degrees of freedom; at most {MAX_DEGREES_OF_FREEDOM} "
                              "are accepted (Pinocchio's data for 400 takes 4.5 GiB)")


def check_joints(robot: ET.Element, origin: str) -> None:
    """Known joint types, unique link and joint names, limits with lower <= upper.

    Pinocchio's URDF parser would print several lines on stderr for duplicate names.
    """
    for kind in ("link", "joint"):
        seen: set[str] = set()
        for element in robot.findall(kind):
            name = element.get("name")
            if not name:
                raise ModelCheckError(f"{origin}: a <{kind}> has no name; every {kind} needs a unique name")
            if name in seen:
                raise ModelCheckError(f"{origin}: two {kind}s are named {name!r}; {kind} names must be unique")
            seen.add(name)
    for joint in robot.findall("joint"):
        name, kind = joint.get("name"), joint.get("type")
        if kind not in JOINT_DEGREES_OF_FREEDOM:
            raise ModelCheckError(f"{origin}: joint {name!r} has type {kind!r}; valid: "
                                  f"{', '.join(JOINT_DEGREES_OF_FREEDOM)}")
        limit = joint.find("limit")
        if limit is not None and "lower" in limit.attrib and "upper" in limit.attrib:
            lower = float(parse_numbers(limit, "lower", origin)[0])
            upper = float(parse_numbers(limit, "upper", origin)[0])
            if lower > upper:
                raise ModelCheckError(f"{origin}: joint {name!r} has limits lower = {lower:g} > upper = {upper:g}; "
                                      "lower must not exceed upper")


def check_urdf(robot: ET.Element, origin: str) -> TreeSummary:
    """Run every check on a parsed URDF and summarize its tree.

    Args:
        robot: the ``<robot>`` element (annotated in place for messages).
        origin: file name or ``"<string>"``, quoted in messages.
    """
    check_size(robot, origin)
    tag_owners(robot)
    check_joints(robot, origin)
    tree = summarize_tree(robot, origin)  # first: every later stage walks the tree (a cycle would never end)
    check_numbers(robot, origin)
    check_joint_axes(robot, origin)
    point_masses = check_inertias(robot, origin)
    check_geometry(robot, origin)
    return replace(tree, point_masses=point_masses)

