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

from ..errors import (
    BaseGuessWarning,
    MissingMeshWarning,
    ModelCheckError,
    ModelFileNotFound,
    ModelParseError,
    ParserWarning,
    UVMSError,
    XacroError,
)
from ..robot.robot import Robot
from . import checks, includes, joint_classes, point_masses, resources, sandbox
from .base_rule import ADDED_BASE_JOINT, decide_base, rigid_body
from .meshes import missing_meshes_note
from .packages import package_index, unknown_package

ROOT_JOINTS = {"floating": pin.JointModelFreeFlyer, "planar": pin.JointModelPlanar}

#: A xacro arg given from outside the file is data: its name a plain identifier, its text a number,
#: true/false or a plain name/path. xacro pastes arg text into ``${...}`` Python expressions, so
#: anything else (parentheses, quotes, operators, dunders) could run code.
ARG_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]{0,63}")
PLAIN_ARG_TEXT = re.compile(r"[A-Za-z0-9_.+\-/]{0,256}")
ARG_RULE = "a number, true/false, or a plain name or path (letters, digits and _ . / + -, at most 256 characters)"


def load(
    source: str | os.PathLike,
    *,
    base: str | None = None,
    args: Mapping[str, object] | None = None,
    ee: str | Sequence[str] | None = None,
    package_path: Sequence[str | os.PathLike] | None = None,
    trusted: bool | None = None,
    arm_joints: Sequence[str] | None = None,
) -> Robot:
    """Load a UVMS from a ``.xacro`` or ``.urdf`` file, a shipped model name, or URDF text.

    The base rule (``base=None``), stated by ``uvms info`` and ``robot.base_reason``:

    * a ``floating``/``planar`` joint at the root link is the vehicle, as written;
    * a plain root link that carries mass (an ``<inertial>`` with mass > 0, e.g. a ``hull``) is a
      vehicle: a free-flying joint ``base_joint`` (``ADDED_BASE_JOINT``) is added above it and a
      :class:`BaseGuessWarning` says so;
    * a massless plain root link (``world``, or an arm's mounting link without ``<inertial>``) is a
      fixed base: an arm on a table.

    This is a toolkit for vehicles, so an arm file whose root link has mass (example-robot-data's
    ``panda``) loads as a free-flying body too: pass ``base="fixed"`` to bolt it to the world
    (``mount_arm`` always mounts an arm fixed to its vehicle).

    Args:
        source: path of a ``.urdf``/``.xacro`` file, the name of a shipped model
            (``"hoang2011"``), or a URDF string (starting with ``<``).
        base: "floating", "planar", "fixed", or None for the rule above. A base that contradicts
            the file's root joint is an error; on a plain root link, "floating"/"planar" adds the
            joint and "fixed" holds the root link (and its mass) in the world.
        args: xacro arguments, ``{name: value}`` (numbers or strings); a value used in
            arithmetic must be a number, and a length that makes a geometry size or a mass
            non-positive is refused (the message names the element).
        ee: end-effector frame name(s); default: one per arm, the frame named like an end effector
            (``end_effector``, ``tool``, ``tcp``, ``ee`` or ``*_<that>``), else the arm's last leaf link
            (:func:`uvms.robot.structure.default_end_effectors`; ``robot.ee_reason`` says which rule chose it).
        package_path: folders of ROS packages (each a package, holding ``package.xml``, or a folder searched
            for packages), first in precedence before ``ROS_PACKAGE_PATH``, ``AMENT_PREFIX_PATH`` and the
            model's own workspace (:mod:`uvms.model.packages`). ``$(find pkg)`` and ``package://pkg/...``
            resolve through these packages only, and an untrusted xacro may read them (besides its own folder
            tree). The robot keeps them as ``robot.packages`` (the viewer finds the meshes there).
        trusted: a xacro file is code (its expressions are Python). True expands it in this
            process; False in a restricted child process (``uvms.model.sandbox``: no file writes, no
            processes, no network, a timeout). None: trusted for the shipped models only.
            Plain URDF is never executed.
        arm_joints: the joints that move besides the vehicle; every other joint is frozen (held at 0, or at its
            limit nearest to 0). None: the rule of :mod:`uvms.model.joint_classes`: propellers (joints carrying
            a thruster), sensor mounts and zero-range joints are frozen, mimic chains composed, every other joint
            is an arm joint. ``robot.joint_classes`` holds each joint's class and why.

    Returns:
        The Robot.

    Raises:
        UVMSError: (a subclass) missing file, malformed XML, xacro error, invalid
            model values, base mismatch, unknown end-effector frame, a mimic cycle or a mimic of a missing
            joint, an ``arm_joints`` entry that is not a joint that can move (the message lists the valid ones).
    """
    path = resources.model_file(source)
    packages = package_index(package_path, path)
    xml, origin, base_dir = model_text(source, path, args, trusted, packages)
    robot_element = checks.parse_urdf(xml, origin)
    try:
        tree = checks.check_urdf(robot_element, origin)
    except ModelCheckError as exc:
        raise ModelCheckError(f"{exc}{blamed_args(exc, source, args, trusted, packages)}") from None
    classified = joint_classes.classify_joints(xml, origin, base_dir, arm_joints)
    chosen, reason = decide_base(base, tree, origin, rigid_body(robot_element, tree.root_link, classified.classes))
    warn_missing_meshes(robot_element, base_dir, packages, origin)
    model = build_model(classified.urdf, chosen, tree, origin)
    point_masses.check_mass_matrix(model, tree.point_masses, origin)
    if model.nv == 0:  # nothing to move, and Pinocchio's Jacobians crash on an empty velocity space
        raise ModelCheckError(f"{origin}: the model has no degree of freedom (fixed base, only fixed joints); "
                              "a UVMS needs a floating/planar base or a moving joint")
    if base is None and chosen != tree.base_type:
        warnings.warn(f"{origin}: the base is {reason}", BaseGuessWarning, stacklevel=2)
    return Robot(model, ee=ee, name=robot_element.get("name"), source=origin, urdf=classified.urdf, base_reason=reason,
                 packages=packages, joint_classes=classified.classes)


def read_model_text(
    source: str | os.PathLike,
    args: Mapping[str, object] | None = None,
    trusted: bool | None = None,
    packages: Mapping[str, Path] | None = None,
) -> tuple[str, str, Path | None]:
    """URDF text of a source, with xacro expanded (in a sandbox unless trusted; see :func:`load`).

    Args:
        packages: the package index for ``$(find)`` (:func:`uvms.model.packages.package_index`); None: that of
            the model alone (``ROS_PACKAGE_PATH``, ``AMENT_PREFIX_PATH``, its workspace).

    Returns:
        (URDF text, origin for messages, folder of the file or None for a string).
    """
    path = resources.model_file(source)
    if packages is None and path is not None and path.name.endswith(".xacro"):
        packages = package_index(model=path)
    return model_text(source, path, args, trusted, packages)


def model_text(source: str | os.PathLike, path: Path | None, args: Mapping[str, object] | None,
               trusted: bool | None, packages: Mapping[str, Path] | None) -> tuple[str, str, Path | None]:
    """:func:`read_model_text` of a source whose file is known: ``path`` (None: ``source`` is URDF text);
    ``packages``: the package index (a xacro file's ``$(find)`` needs one)."""
    if path is None:
        if args:
            raise UVMSError("xacro args were given with a URDF string; args apply to .xacro files only")
        return str(source), "<string>", None
    origin = str(path)
    if path.name.endswith(".xacro"):
        if trusted is None:
            trusted = path.resolve().is_relative_to(resources.MODELS_DIR)
        return expand_xacro(path, args or {}, trusted, packages), origin, path.parent
    if args:
        raise UVMSError(f"{origin}: xacro args were given but the file is not a .xacro")
    return resources.read_text(path, "model", checks.MAX_URDF_BYTES, ModelFileNotFound), origin, path.parent


def expand_xacro(path: Path, args: Mapping[str, object], trusted: bool, packages: Mapping[str, Path]) -> str:
    """Run xacro on a file with ``args`` as its mappings (``$(find)`` through the package index ``packages``);
    untrusted files in ``uvms.model.sandbox``.

    Raises:
        XacroError: xacro failed (its message is kept, and a given arg that is text where the model's
            default is a number is named).
        ModelParseError: the file is not well-formed XML.
    """
    mappings = {check_arg_name(key, path): format_xacro_value(key, value, path) for key, value in args.items()}
    declared = declared_xacro_defaults(path, packages)
    unknown = sorted(set(mappings) - set(declared)) if declared is not None else []
    if unknown:
        raise XacroError(
            f"{path}: unknown xacro arg(s) {', '.join(unknown)}; this model declares: {', '.join(sorted(declared))}"
        )
    try:
        return run_xacro(path, mappings, trusted, packages)
    except XacroError as exc:
        raise XacroError(f"{exc}{non_numeric_args(path, mappings, packages)}") from None


def run_xacro(path: Path, mappings: Mapping[str, str], trusted: bool, packages: Mapping[str, Path]) -> str:
    """xacro on a file with checked ``mappings``: in this process when trusted, else in ``uvms.model.sandbox``.

    ``$(find pkg)`` is the folder of ``pkg`` in the package index ``packages`` (an unknown package: an error
    saying where uvms looked); xacro's own resolution is back in place afterwards. An untrusted file may read
    its own folder tree and the folders of ``packages``, nothing else.
    """
    import xacro  # imported here: it is slow to import and only needed for .xacro

    from .sandbox_worker import PackageNotFound, missing_package, packages_for_find

    if not trusted:
        return sandbox.expand_untrusted(path, mappings, packages=packages)
    try:
        with packages_for_find(packages):
            document = xacro.process_file(str(path), mappings=mappings)
    except RecursionError:
        raise XacroError(f"{path}: xacro recursion too deep (does the file include itself?)") from None
    except (xacro.XacroException, PackageNotFound) as exc:
        if missing_package(exc) is not None:
            raise XacroError(unknown_package(missing_package(exc), packages, path)) from None
        raise XacroError(f"{path}: xacro error: {' '.join(str(exc).split())}") from None
    except ExpatError as exc:
        raise ModelParseError(f"{path}: malformed XML ({exc})") from None
    except (OSError, ValueError, TypeError, NameError) as exc:
        raise XacroError(f"{path}: xacro error: {exc}") from None
    return document.toprettyxml(indent="  ")


def declared_xacro_defaults(path: Path, packages: Mapping[str, Path] | None = None) -> dict[str, str | None] | None:
    """{name: default text (None without one)} of the ``<xacro:arg>`` of a file and its static includes (those
    named ``$(find pkg)/...`` too, through the package index ``packages``).

    Read by :func:`uvms.model.includes.walk_xacro` (each file once, within its caps).

    Returns:
        The args, or None when they cannot be known here (an unparsable or missing file, an include whose name
        is computed, an include cycle): the arg check is then left to xacro.

    Raises:
        XacroError: an include that is not a readable regular file (a FIFO, a symbolic link loop, too large), or
            includes beyond the walk's caps.
    """
    walk = includes.walk_xacro(path, packages)
    if walk.problem is not None:
        raise walk.problem
    return walk.args


def is_number_text(text: str | None) -> bool:
    """Whether xacro arg text is a number (or an expression ``${...}``, as numeric defaults often are)."""
    if text is None:
        return False
    try:
        float(text)
    except ValueError:
        return text.strip().startswith("${")
    return True


def non_numeric_args(path: Path, mappings: Mapping[str, str], packages: Mapping[str, Path] | None = None) -> str:
    """The explanation of a xacro failure by args given as text where the model's default is a number.

    Returns:
        "; xacro arg l1='abc' is not a number, but the model computes with it (its default is 0.4): give a
        number", or "" when no given arg is such.
    """
    defaults = declared_xacro_defaults(path, packages) or {}
    suspects = [f"xacro arg {name}={value!r} is not a number, but the model computes with it (its default is "
                f"{defaults[name]})" for name, value in mappings.items()
                if not is_number_text(value) and value not in ("true", "false") and is_number_text(defaults.get(name))]
    return f"; {'; '.join(suspects)}: give a number" if suspects else ""


def blamed_args(
    error: ModelCheckError, source: str | os.PathLike, args: Mapping[str, object] | None, trusted: bool | None,
    packages: Mapping[str, Path] | None = None,
) -> str:
    """Which given xacro args a model check failure comes from: those without which the failure goes away.

    Each arg is left out in turn (its default used) and the model expanded and checked again; this runs
    only after a failure, once per given arg.

    Returns:
        " (from xacro arg l1=-0.4: with its default 0.4 the model passes this check)", or "".
    """
    if not args or len(args) > 16:
        return ""
    path = resources.resolve_model_path(source)
    defaults = declared_xacro_defaults(path, packages) or {}
    blamed = []
    for name in args:
        others = {key: value for key, value in args.items() if key != name}
        try:
            xml, origin, _ = read_model_text(source, others, trusted, packages)
            checks.check_urdf(checks.parse_urdf(xml, origin), origin)
        except ModelCheckError as again:
            if str(again) == str(error):
                continue
        except UVMSError:
            continue
        blamed.append(name)
    if not blamed:
        return ""
    given = ", ".join(f"{name}={args[name]!r}" for name in blamed)
    default = ", ".join(f"{defaults.get(name)}" for name in blamed)
    its = "its default" if len(blamed) == 1 else "their defaults"
    return f" (from xacro arg {given}: with {its} {default} the model passes this check)"


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
    packages: Mapping[str, Path],
    origin: str,
) -> dict[str, Path]:
    """Resolve every mesh URI (``package://`` through the package index); warn (once per model) about the ones
    that cannot be found.

    Returns:
        {URI: resolved file} for the meshes found.
    """
    found: dict[str, Path] = {}
    missing: list[str] = []
    for mesh in robot_element.iter("mesh"):
        uri = mesh.get("filename", "")
        if uri in found or uri in missing:
            continue
        path = resources.resolve_uri(uri, base_dir, packages)
        if path is None:
            missing.append(uri)
        else:
            found[uri] = path
    if missing:
        model = origin if base_dir is not None else ""  # a URDF string has no workspace
        warnings.warn(missing_meshes_note(origin, missing, base_dir, packages, model), MissingMeshWarning,
                      stacklevel=3)
    return found
