"""Loading a UVMS from xacro/URDF: expand, check, choose the base, build the Pinocchio model."""

from __future__ import annotations

import contextlib
import math
import numbers
import os
import re
import sys
import tempfile
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from xml.parsers.expat import ExpatError

import pinocchio as pin

from . import checks, resources, sandbox
from ..errors import BaseMismatchError, ModelCheckError, ModelFileNotFound, ModelParseError, UVMSError, XacroError
from ..robot import Robot

BASE_CHOICES = ("floating", "planar", "fixed")
ROOT_JOINTS = {"floating": pin.JointModelFreeFlyer, "planar": pin.JointModelPlanar}
#: Name given to a vehicle joint that uvms adds (base="floating"/"planar" on a plain root link).
ADDED_BASE_JOINT = "base_joint"

#: A xacro arg given from outside the file is data: its name a plain identifier, its text a number,
#: true/false or a plain name/path. xacro pastes arg text into ``${...}`` Python expressions, so
#: anything else (parentheses, quotes, operators, dunders) could run code.
ARG_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]{0,63}")
PLAIN_ARG_TEXT = re.compile(r"[A-Za-z0-9_.+\-/]{0,256}")
ARG_RULE = "a number, true/false, or a plain name or path (letters, digits and _ . / + -, at most 256 characters)"


class MissingMeshWarning(UserWarning):
    """A mesh of the model cannot be found; kinematics does not need it."""


class ParserWarning(UserWarning):
    """Pinocchio's URDF parser printed something while building a model it accepted."""


def load(
    source: str | os.PathLike,
    *,
    base: str | None = None,
    args: Mapping[str, object] | None = None,
    ee: str | Sequence[str] | None = None,
    package_dirs: Sequence[str | os.PathLike] | None = None,
    trusted: bool | None = None,
) -> Robot:
    """Load a UVMS from a ``.xacro`` or ``.urdf`` file, a shipped model name, or URDF text.

    Args:
        source: path of a ``.urdf``/``.xacro`` file, the name of a shipped model
            (``"hoang2011"``), or a URDF string (starting with ``<``).
        base: "floating", "planar", "fixed", or None for the root joint written
            in the file (a ``floating``/``planar`` joint at the root link is the
            vehicle; a plain root link is a fixed base). A base that contradicts
            the file is an error; "floating"/"planar" on a plain root adds the joint.
        args: xacro arguments, ``{name: value}`` (numbers or strings).
        ee: end-effector frame name(s); default: frames named ``ee``/``*_ee``,
            else the last leaf link.
        package_dirs: extra folders to resolve ``package://`` mesh URIs.
        trusted: a xacro file is code (its expressions are Python). True expands it in this
            process; False in a restricted child process (``uvms.sandbox``: no file writes, no
            processes, no network, a timeout). None: trusted for the shipped models only.
            Plain URDF is never executed.

    Returns:
        The Robot.

    Raises:
        UVMSError: (a subclass) missing file, malformed XML, xacro error, invalid
            model values, base mismatch, unknown end-effector frame.
    """
    xml, origin, base_dir = read_model_text(source, args, trusted)
    robot_element = checks.parse_urdf(xml, origin)
    tree = checks.check_urdf(robot_element, origin)
    chosen = choose_base(base, tree, origin)
    warn_missing_meshes(robot_element, base_dir, package_dirs, origin)
    model = build_model(xml, chosen, tree, origin)
    if model.nv == 0:  # nothing to move, and Pinocchio's Jacobians crash on an empty velocity space
        raise ModelCheckError(f"{origin}: the model has no degree of freedom (fixed base, only fixed joints); "
                              "a UVMS needs a floating/planar base or a moving joint")
    return Robot(model, ee=ee, name=robot_element.get("name"), source=origin, urdf=xml)


def read_model_text(
    source: str | os.PathLike, args: Mapping[str, object] | None = None, trusted: bool | None = None
) -> tuple[str, str, Path | None]:
    """URDF text of a source, with xacro expanded (in a sandbox unless trusted; see :func:`load`).

    Returns:
        (URDF text, origin for messages, folder of the file or None for a string).
    """
    if isinstance(source, str) and source.lstrip().startswith("<"):
        if args:
            raise UVMSError("xacro args were given with a URDF string; args apply to .xacro files only")
        return source, "<string>", None
    path = resources.resolve_model_path(source)
    origin = str(path)
    if path.name.endswith(".xacro"):
        if trusted is None:
            trusted = path.resolve().is_relative_to(resources.MODELS_DIR)
        return expand_xacro(path, args or {}, trusted), origin, path.parent
    if args:
        raise UVMSError(f"{origin}: xacro args were given but the file is not a .xacro")
    try:
        return path.read_text(encoding="utf-8"), origin, path.parent
    except (OSError, UnicodeDecodeError) as exc:
        raise ModelFileNotFound(f"{origin}: cannot read the model file ({exc})") from None


def expand_xacro(path: Path, args: Mapping[str, object], trusted: bool = True) -> str:
    """Run xacro on a file with ``args`` as its mappings; untrusted files in ``uvms.sandbox``.

    Raises:
        XacroError: xacro failed (its message is kept).
        ModelParseError: the file is not well-formed XML.
    """
    import xacro  # imported here: it is slow to import and only needed for .xacro

    mappings = {check_arg_name(key, path): format_xacro_value(key, value, path) for key, value in args.items()}
    declared = declared_xacro_args(path)
    unknown = sorted(set(mappings) - declared) if declared is not None else []
    if unknown:
        raise XacroError(
            f"{path}: unknown xacro arg(s) {', '.join(unknown)}; this model declares: {', '.join(sorted(declared))}"
        )
    if not trusted:
        return sandbox.expand_untrusted(path, mappings)
    try:
        document = xacro.process_file(str(path), mappings=mappings)
    except RecursionError:
        raise XacroError(f"{path}: xacro recursion too deep (does the file include itself?)") from None
    except xacro.XacroException as exc:
        raise XacroError(f"{path}: xacro error: {' '.join(str(exc).split())}") from None
    except ExpatError as exc:
        raise ModelParseError(f"{path}: malformed XML ({exc})") from None
    except (OSError, ValueError, TypeError, NameError) as exc:
        raise XacroError(f"{path}: xacro error: {exc}") from None
    return document.toprettyxml(indent="  ")


def declared_xacro_args(path: Path, _seen: frozenset[Path] = frozenset()) -> set[str] | None:
    """Names of the ``<xacro:arg>`` declared in a file and its static includes.

    Returns None when that cannot be known here (unparsable file, an include
    whose name is computed, an include cycle): the arg check is then left to xacro.
    """
    namespace = "{http://www.ros.org/wiki/xacro}"
    resolved = path.resolve()
    if resolved in _seen:
        return None  # an include cycle: xacro reports it
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError):
        return None  # xacro reports the real problem
    names = {element.get("name") for element in root.iter(namespace + "arg")}
    for include in root.iter(namespace + "include"):
        filename = include.get("filename", "")
        if "$" in filename:
            return None
        included = declared_xacro_args(path.parent / filename, _seen | {resolved})
        if included is None:
            return None
        names |= included
    return names


def check_arg_name(name: object, path: Path) -> str:
    """A xacro arg name from outside the file: a plain identifier.

    Raises:
        XacroError: anything else.
    """
    if not isinstance(name, str) or not ARG_NAME.fullmatch(name):
        raise XacroError(f"{path}: xacro arg name {name!r} is not allowed; a name is letters, digits and _ "
                         "(not starting with a digit, at most 64 characters)")
    return name


def format_xacro_value(name: str, value: object, path: Path | str = "<model>") -> str:
    """The text of a xacro arg given from outside the file, which must be data (see ``ARG_RULE``).

    Numbers are printed exactly (repr), booleans as xacro spells them.

    Raises:
        XacroError: a non-finite number, a string that is not a plain name/path, or another type.
    """
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if isinstance(value, numbers.Real):
        if not math.isfinite(value):
            raise XacroError(f"{path}: xacro arg {name}={value!r} is not finite; give {ARG_RULE}")
        return repr(float(value))
    if isinstance(value, str) and PLAIN_ARG_TEXT.fullmatch(value) and "__" not in value:
        return value
    raise XacroError(f"{path}: xacro arg {name}={value!r} is not allowed: an arg from outside the file is data, "
                     f"{ARG_RULE}")


def choose_base(requested: str | None, tree: checks.TreeSummary, origin: str) -> str:
    """The base type to build: the file's, or the requested one when compatible."""
    if requested is None:
        return tree.base_type
    if requested not in BASE_CHOICES:
        raise UVMSError(f"unknown base {requested!r}; valid: {', '.join(BASE_CHOICES)} or None (as in the file)")
    if tree.base_type != "fixed" and requested != tree.base_type:
        raise BaseMismatchError(
            f"{origin}: base={requested!r} contradicts the file, whose root joint {tree.base_joint!r} is "
            f"{tree.base_type}; use base={tree.base_type!r} or None, or edit the model"
        )
    return requested


def build_model(xml: str, base: str, tree: checks.TreeSummary, origin: str) -> pin.Model:
    """Build the Pinocchio model, adding a vehicle joint when asked for one the file lacks."""
    with captured_stderr() as printed:
        try:
            if base in ROOT_JOINTS and tree.base_type == "fixed":
                model = pin.buildModelFromXML(xml, ROOT_JOINTS[base](), ADDED_BASE_JOINT, mimic=True)
            else:
                model = pin.buildModelFromXML(xml, mimic=True)
        except (RuntimeError, ValueError) as exc:
            failure = " ".join(str(exc).split())
        else:
            failure = None
    said = " ".join(" ".join(printed).split())
    if failure is not None:
        raise ModelParseError(f"{origin}: Pinocchio cannot build the model: {failure or said or 'no reason given'}")
    if said:
        warnings.warn(f"{origin}: Pinocchio's URDF parser said: {said[:300]}", ParserWarning, stacklevel=3)
    return model


@contextlib.contextmanager
def captured_stderr() -> Iterator[list[str]]:
    """Hold what C++ code prints on file descriptor 2 (urdfdom does) and hand it over as lines.

    The messages then reach the user as one line of an error or a warning, not as raw multi-line output.
    """
    lines: list[str] = []
    sys.stderr.flush()
    with tempfile.TemporaryFile() as held:
        saved = os.dup(2)
        os.dup2(held.fileno(), 2)
        try:
            yield lines
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            held.seek(0)
            lines.extend(held.read(1 << 16).decode(errors="replace").splitlines())


def warn_missing_meshes(
    robot_element: ET.Element,
    base_dir: Path | None,
    package_dirs: Sequence[str | os.PathLike] | None,
    origin: str,
) -> dict[str, Path]:
    """Resolve every mesh URI; warn (once per model) about the ones that cannot be found.

    Returns:
        {URI: resolved file} for the meshes found.
    """
    roots = resources.package_search_roots(package_dirs)
    found: dict[str, Path] = {}
    missing: list[str] = []
    for mesh in robot_element.iter("mesh"):
        uri = mesh.get("filename", "")
        if uri in found or uri in missing:
            continue
        path = resources.resolve_uri(uri, base_dir, roots)
        if path is None:
            missing.append(uri)
        else:
            found[uri] = path
    if missing:
        warnings.warn(
            f"{origin}: {len(missing)} mesh file(s) not found (e.g. {missing[0]!r}); kinematics is unaffected. "
            f"Pass package_dirs= or set ROS_PACKAGE_PATH to show them.",
            MissingMeshWarning,
            stacklevel=3,
        )
    return found
