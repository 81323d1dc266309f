"""The exceptions of uvms: one root, one subclass per kind of bad input.

Every message says what was wrong and what would be valid, so that the CLI can
print it as a single line and a notebook user can act on it without a traceback.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable


class UVMSError(Exception):
    """Root of every error raised by uvms on bad input."""


class ModelFileNotFound(UVMSError):
    """A model path does not exist or cannot be read."""


class ModelParseError(UVMSError):
    """A model is not well-formed XML / URDF."""


class XacroError(UVMSError):
    """xacro failed to expand a model (undefined arg or property, bad include...)."""


class ModelCheckError(UVMSError):
    """A URDF element has an invalid value (axis, number, mass, inertia...)."""


class BaseMismatchError(UVMSError):
    """The requested vehicle base contradicts the root joint written in the file."""


class NoVehicleError(ModelCheckError):
    """A vehicle quantity (generalized Jacobian, vehicle velocity, eta/nu) was asked of a fixed-base model."""


class NameNotFound(UVMSError):
    """A frame or joint name is not in the model."""

    def __init__(self, kind: str, name: str, valid: Iterable[str], first: Iterable[str] = (), where: str = "") -> None:
        valid = list(valid)
        first = [n for n in first if n in valid]  # always suggested (e.g. a model's root link), before the others
        close = first + [n for n in difflib.get_close_matches(name, valid, n=5, cutoff=0.4) if n not in first]
        hint = f"close names: {', '.join(close)}" if close else f"valid names: {', '.join(valid[:20])}"
        super().__init__(f"{where + ': ' if where else ''}unknown {kind} {name!r}; {hint}")
        self.name = name
        self.valid = valid


class FrameNotFound(NameNotFound):
    """A frame name is not in the model; the message lists the close names."""

    def __init__(self, name: str, valid: Iterable[str], first: Iterable[str] = ()) -> None:
        super().__init__("frame", name, valid, first)


class JointNotFound(NameNotFound):
    """A joint name is not in the model; the message lists the close names."""

    def __init__(self, name: str, valid: Iterable[str]) -> None:
        super().__init__("joint", name, valid)


class LinkNotFound(NameNotFound, ModelCheckError):
    """A link name (of a collision pair, an SRDF entry) is not in the model; the message lists the close names."""

    def __init__(self, name: str, valid: Iterable[str], where: str = "") -> None:
        super().__init__("link", name, valid, where=where)


class ConfigurationError(UVMSError):
    """A configuration, velocity or pose has the wrong size or non-finite entries."""


class NotARobot(UVMSError, TypeError):
    """Something other than a :class:`uvms.Robot` where a function needs the model (``uvms.load`` returns one)."""


class WorkspaceInputError(UVMSError):
    """A workspace argument out of range: sample count, voxel size, orientation grid, hull."""


# ------------------------------------------------- scenarios, runs and their output folders
class ScenarioError(UVMSError):
    """A scenario file or override is invalid (unknown key, wrong type, impossible value)."""


class StepCountError(UVMSError):
    """A step ``dt`` and a duration that give no step at all, or more than ``uvms.numerics.integrate.MAX_STEPS``;
    or a controller period ``control_dt`` that is not a multiple of ``dt``."""


class NumericalError(UVMSError):
    """The numerics of a run failed (OverflowError, FloatingPointError, LinAlgError): a number out of range."""


class SweepError(UVMSError):
    """A sweep is invalid (grid syntax, unknown key, backend) or cannot start."""


class StudyError(UVMSError):
    """A Monte Carlo study or a tuning is invalid (distribution, key, method, backend) or its folder holds another."""


class RunFolderError(UVMSError):
    """An output folder cannot be replaced: unwritable, a file, or a folder that uvms did not write."""


class RunFolderBusy(RunFolderError):
    """Another uvms process is writing the same output folder (it holds the folder's lock)."""


class DiskFullError(RunFolderError):
    """No space is left (or the quota is exhausted) on the device holding an output folder."""


class RunRecordError(UVMSError):
    """A run folder's record of its model is malformed, or contradicts the model given with the folder."""


# ------------------------------------------------- solvers and controllers
class SolverInputError(UVMSError):
    """A Jacobian, weight, gain or damping of the wrong shape, non-finite or not positive definite."""


class GJMControlError(UVMSError):
    """Invalid input to the GJM controller or its reference (shape, value, option)."""


class LimitError(UVMSError):
    """Joint limits (a ``Limit``) that are invalid or do not fit their use: bounds inverted or NaN, a margin that is
    negative or leaves no room, speed limits <= 0, or the wrong size or kind (position, velocity) for the robot."""


# ------------------------------------------------- optional extras
class ViewerUnavailable(UVMSError):
    """The optional 3-D viewer package (viser) is not installed."""


class TeachUnavailable(UVMSError):
    """ipywidgets is not installed."""


class BagExportError(UVMSError):
    """A run cannot be written as a ROS 2 bag: rosbags is not installed, or the run does not fit the robot."""


# ------------------------------------------------- inequality objectives (set-based control, QP hierarchy)
class IdentificationError(UVMSError):
    """A log cannot be used for hydrodynamic identification (truncated or unreadable, a missing topic or column, a
    wrong message type, non-finite rows, too short or not matching the model), or an identification option is
    invalid."""


class ObjectiveError(UVMSError):
    """An inequality objective or a velocity limit has an invalid parameter (margin, band, bound, normal,
    gain) or does not fit the model (a vehicle objective on a fixed base)."""


class ObjectiveNameNotFound(NameNotFound):
    """An unknown inequality type, or an unknown parameter of one; the message lists the close names."""


# ------------------------------------------------- the browser viewer
class ViewerInputError(UVMSError):
    """A viewer argument out of range (port), or a run's ``trajectory.npz`` the viewer will not read."""


# ------------------------------------------------- warnings: what uvms did that the user should know (a guess, a
# default taken, a file left out); never a failure
class UVMSWarning(UserWarning):
    """Root of every warning uvms gives (``warnings.simplefilter("error", uvms.errors.UVMSWarning)`` makes them
    errors)."""


class AddedMassSymmetrizedWarning(UVMSWarning):
    """An added-mass matrix that was symmetric within :data:`uvms.dynamics.hydro.parameters.MATRIX_TOLERANCE` was
    replaced by (M + M^T) / 2."""


class BaseGuessWarning(UVMSWarning):
    """``load`` chose the vehicle base by the root-link rule and added a joint the file does not have."""


class JointOrderWarning(UVMSWarning):
    """``uvms.load`` of a composed URDF would order the joints differently from the composed model."""


class MissingMeshWarning(UVMSWarning):
    """A mesh of the model cannot be found; kinematics does not need it."""


class OutputFailedWarning(UVMSWarning):
    """A figure or bag of a run could not be written (a defect of uvms); the run's data are complete."""


class PackageSearchWarning(UVMSWarning):
    """A search for ROS packages stopped at a bound, or met a ``package.xml`` it cannot read or two of one name."""


class ParserWarning(UVMSWarning):
    """Pinocchio's URDF parser printed something while building a model it accepted."""


class PluginSettingWarning(UVMSWarning):
    """A simulator plugin's setting that uvms does not follow; the message says what uvms does instead."""


class PointMassWarning(UVMSWarning):
    """A link has a positive mass and an all-zero inertia (a point mass), as uuv_simulator's thruster links do."""


class ShapeCoefficientWarning(UVMSWarning):
    """A shape model took a coefficient that uuv_simulator leaves undefined (a cylinder longer than its table)."""


class SkippedLinkWarning(UVMSWarning):
    """A hydrodynamic plugin block names a link the model does not have and is skipped, as Gazebo does (``--strict``
    or ``warnings.simplefilter("error", SkippedLinkWarning)`` refuses it)."""


class ThrusterDefaultWarning(UVMSWarning):
    """A plugin thruster took a value of :data:`uvms.dynamics.thrusters.thrusters.DEFAULT_VALUES` (the plugin and the
    YAML give none)."""


class FinDefaultWarning(UVMSWarning):
    """A fin took :data:`uvms.dynamics.thrusters.fins.DEFAULT_TIME_CONSTANT` (its plugin gives no first-order time
    constant), or a fin plugin is left out of the plant (its joint is not a fin: ``arm_joints`` makes it an arm
    joint)."""


class ThrusterLayoutWarning(UVMSWarning):
    """The thrusters cannot produce every body-wrench direction (the allocation's rank is below 6)."""


class ThrusterFileWarning(UVMSWarning):
    """The ``thrusters.yaml`` beside a model cannot be read: the propellers it names are not known when loading
    (``uvms.dynamics.thrusters_of`` raises the same error when the thrusters are used)."""


class CollidingPairWarning(UVMSWarning):
    """Pairs of links in collision at the reference configuration were disabled (no SRDF says which to check)."""


class GeometryWarning(UVMSWarning):
    """A geometry element of the model is left out of a drawing or a hull (an unsupported shape, an unreadable mesh)."""


class InsecureSchedulerWarning(UVMSWarning):
    """A Dask scheduler is reached without TLS (``insecure_scheduler=True``): anyone who can reach it can run code on
    its workers and, through the pickled results, in the uvms process."""


class StudyResumeWarning(UVMSWarning):
    """A resumed study found rows that are not the trials they claim (edited, truncated, of another trial): those
    trials run again."""
