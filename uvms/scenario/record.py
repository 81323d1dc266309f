"""The record of a run's model in its folder: ``metrics.json``'s ``"model"`` entry, read back by ``uvms view``.

A run folder says which model it ran on, so ``uvms view --result DIR`` draws it on that geometry and nothing
else::

    "model": {
      "source": "/home/me/uvms/models/hoang2011/uvms.urdf.xacro",   # a shipped name stays a name
      "args": {"l1": 0.7},                                            # xacro args as the run used them
      "base": "planar",                                               # the base the run had
      "ee": ["ee"],                                                   # its end-effector frames
      "package_path": ["/home/me/ws/src"],                            # its package folders (model.package_path)
      "arm_joints": null,                                             # [model] arm_joints (null: the rule)
      "scenario": "hoang2011_w1",
      "robot": "hoang2011_uvms", "nq": 7, "nv": 6,
      "urdf_sha256": "3f1c..."                                        # of the expanded URDF (None if composed)
    }

The record is data from a folder someone else may have written: every field is checked, the model is loaded
by :func:`uvms.model.loader.load` (an untrusted xacro runs in its sandbox) and its args are literals; its package
folders are only read from, as a scenario's ``model.package_path``.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import RunRecordError, UVMSError
from ..model import resources
from ..model.loader import load
from ..robot.robot import Robot
from .spec import ModelSpec, ScenarioSpec

RECORD_KEY = "model"
BASES = ("floating", "planar", "fixed")
#: Two models draw a run alike when every joint and frame placement agrees to this [m, rotation entries].
PLACEMENT_TOLERANCE = 1e-9


def urdf_digest(robot: Robot) -> str | None:
    """SHA-256 of the URDF text a robot was built from (None when it has none, e.g. composed)."""
    return hashlib.sha256(robot.urdf.encode("utf-8")).hexdigest() if robot.urdf else None


def model_record(spec: ScenarioSpec, robot: Robot) -> dict:
    """The ``"model"`` entry of a run's ``metrics.json``: the model as given (a shipped name, or the file's absolute
    path), its xacro args, the base type and end effectors of the robot built, and the scenario name."""
    given = str(spec.model.path)
    path = Path(given).expanduser()
    source = str(path.resolve()) if path.is_file() else given
    return {
        "source": source,
        "args": dict(spec.model.args),
        "base": robot.base_type,
        "ee": list(robot.ee_frames),
        "package_path": list(spec.model.package_path),
        "arm_joints": None if spec.model.arm_joints is None else list(spec.model.arm_joints),
        "scenario": spec.scenario.name,
        "robot": robot.name,
        "nq": robot.nq,
        "nv": robot.nv,
        "urdf_sha256": urdf_digest(robot),
    }


@dataclass
class RunRecord:
    """The model a run folder records (see the module docstring)."""

    folder: Path
    source: str
    args: dict = field(default_factory=dict)
    base: str = "floating"
    ee: list[str] = field(default_factory=list)
    package_path: list[str] = field(default_factory=list)
    arm_joints: list[str] | None = None  # [model] arm_joints (None: uvms.load's rule)
    scenario: str = ""
    urdf_sha256: str | None = None

    def load(self, package_path: Sequence[str | os.PathLike] = ()) -> Robot:
        """The run's robot: its model with its args, base and end effectors, its packages found in ``package_path``
        (e.g. ``--package-path``) and then in the recorded folders.

        Raises:
            RunRecordError: the model cannot be loaded (the message says why, and that the run folder records it).
        """
        try:
            return load(self.source, base=self.base, args=self.args or None, ee=self.ee or None,
                        package_path=[*package_path, *self.package_path],
                        arm_joints=self.arm_joints)
        except UVMSError as exc:
            raise RunRecordError(f"the model recorded by {self.folder / 'metrics.json'} does not load: {exc}") from None

    def describe(self) -> str:
        """``/path/uvms.urdf.xacro (args l1=0.7, base planar)``."""
        args = ", ".join(f"{key}={value}" for key, value in self.args.items()) or "none"
        return f"{self.source} (args {args}, base {self.base})"

    def changed_since(self, robot: Robot) -> bool:
        """Whether the model files changed after the run (their expanded URDF differs from the recorded one)."""
        digest = urdf_digest(robot)
        return self.urdf_sha256 is not None and digest is not None and digest != self.urdf_sha256


def read_run_record(folder: str | os.PathLike) -> RunRecord | None:
    """The record of a run folder, or None when it has none (a run of an older uvms, or no metrics.json).

    Raises:
        RunRecordError: metrics.json cannot be read, or its ``"model"`` entry is malformed.
    """
    folder = Path(folder)
    path = folder / "metrics.json"
    if not path.is_file():
        return None
    metrics = resources.read_json(path, "run record", RunRecordError)
    entry = metrics.get(RECORD_KEY) if isinstance(metrics, dict) else None
    if not isinstance(entry, dict):  # older runs; a workspace folder names its model with a string
        return None

    def bad(what: str) -> RunRecordError:
        return RunRecordError(f"{path}: the \"model\" entry is malformed: {what}; rerun the scenario, or give the "
                              f"model (uvms view MODEL --result DIR)")

    source, args, base, ee = entry.get("source"), entry.get("args", {}), entry.get("base"), entry.get("ee", [])
    if not isinstance(source, str) or not source:
        raise bad("source must be a model file or a shipped model name")
    if not isinstance(args, dict) or not all(isinstance(key, str) and isinstance(value, (bool, int, float, str))
                                             for key, value in args.items()):
        raise bad("args must map names to numbers, booleans or strings")
    if base not in BASES:
        raise bad(f"base must be one of {', '.join(BASES)}, got {base!r}")
    if not isinstance(ee, list) or not all(isinstance(frame, str) for frame in ee):
        raise bad("ee must be a list of frame names")
    package_path = entry.get("package_path", [])
    if not isinstance(package_path, list) or not all(isinstance(folder, str) and folder for folder in package_path):
        raise bad("package_path must be a list of folders")
    arm_joints = entry.get("arm_joints")
    if arm_joints is not None and (not isinstance(arm_joints, list) or not all(isinstance(n, str) for n in arm_joints)):
        raise bad("arm_joints must be a list of joint names or null")
    digest = entry.get("urdf_sha256")
    scenario = entry.get("scenario", "")
    return RunRecord(folder=folder, source=source, args=dict(args), base=base, ee=list(ee), package_path=package_path,
                     arm_joints=arm_joints,
                     scenario=scenario if isinstance(scenario, str) else "",
                     urdf_sha256=digest if isinstance(digest, str) else None)


def model_difference(recorded: Robot, given: Robot) -> str | None:
    """How two models differ in what a replay draws (base, joints, joint and frame placements), or None."""
    if recorded.base_type != given.base_type:
        return f"base {given.base_type} instead of {recorded.base_type}"
    names = [joint.name for joint in recorded.joints]
    if [joint.name for joint in given.joints] != names or given.nq != recorded.nq:
        return f"joints {', '.join(j.name for j in given.joints)} instead of {', '.join(names)}"
    for index in range(1, recorded.model.njoints):
        if not np.allclose(recorded.model.jointPlacements[index].homogeneous,
                           given.model.jointPlacements[index].homogeneous, atol=PLACEMENT_TOLERANCE):
            return f"joint {recorded.model.names[index]} placed differently"
    given_frames = {frame.name: frame for frame in given.model.frames}
    for frame in recorded.model.frames:
        other = given_frames.get(frame.name)
        if other is None:
            return f"no frame {frame.name}"
        if other.parentJoint != frame.parentJoint or not np.allclose(
                frame.placement.homogeneous, other.placement.homogeneous, atol=PLACEMENT_TOLERANCE):
            return f"frame {frame.name} placed differently"
    return None


def check_given_model(record: RunRecord, recorded: Robot, given: Robot, given_text: str) -> None:
    """Refuse a model given with ``--result`` that would draw the run on another geometry than the recorded one.

    Raises:
        RunRecordError: the models differ; the message names the difference and the recorded model.
    """
    difference = model_difference(recorded, given)
    if difference is not None:
        raise RunRecordError(f"{given_text} contradicts the model {record.folder} was run on, "
                             f"{record.describe()}: {difference}; drop the model argument (uvms view --result "
                             f"{record.folder}) to replay it on its own model")



def scenario_model(section: ModelSpec, args: Mapping[str, object] | None = None, base: str | None = None,
                   package_path: Sequence[str | os.PathLike] = (), ee: Sequence[str] | None = None,
                   arm_joints: Sequence[str] | None = None) -> Robot:
    """The robot of a scenario's checked ``[model]`` section (the one way a scenario loads its model), with
    ``args`` over its xacro args, ``base``, ``ee`` and ``arm_joints`` (None: the section's) over its own and the
    folders of ``package_path`` first."""
    return load(section.path, base=base or section.base or None, args={**section.args, **(args or {})} or None,
                ee=ee or section.ee or None, package_path=[*package_path, *section.package_path],
                arm_joints=section.arm_joints if arm_joints is None else arm_joints)


def named_model(model: str, args: Mapping[str, object] | None = None, base: str | None = None,
                package_path: Sequence[str | os.PathLike] = (), ee: Sequence[str] | None = None,
                arm_joints: Sequence[str] | None = None) -> Robot:
    """A model named on a command line: a model file or shipped name, or the ``[model]`` of a scenario ``.toml``
    (or shipped scenario name ending in ``.toml``): :func:`scenario_model` with these overrides; ``arm_joints``
    as :func:`uvms.load` takes it (None: the rule, or the scenario's ``arm_joints``)."""
    args = dict(args or {})
    if str(model).endswith(".toml"):
        from .schema import read_scenario

        return scenario_model(read_scenario(model).model, args, base, package_path, ee, arm_joints)
    return load(model, base=base, args=args, package_path=package_path, ee=ee or None, arm_joints=arm_joints)


def replay_model(folder: str | os.PathLike, model: str | None = None, args: Mapping[str, object] | None = None,
                 base: str | None = None, package_path: Sequence[str | os.PathLike] = ()) -> tuple[Robot, str | None]:
    """The robot to draw the run of ``folder`` on, and a one-line note about it (None: nothing to note).

    A folder that records its model (:func:`read_run_record`) is drawn on that model; a ``model``, ``args`` or
    ``base`` given as well must describe the same geometry (:func:`check_given_model`). A folder of an older
    uvms, without a record, is drawn on ``model`` as given, with a note saying so.

    Raises:
        RunRecordError: a malformed record, a recorded model that does not load, or a contradicting model;
        UVMSError: no record and no ``model``, or a model that does not load.
    """
    if not Path(folder).is_dir():
        raise UVMSError(f"{str(folder)!r} does not exist; --result takes a run folder written by `uvms run`")
    record = read_run_record(folder)
    if record is None:
        if model is None:
            raise UVMSError(f"uvms view needs the model: {folder} does not record it (a run of an older uvms); "
                            f"give it: uvms view MODEL|SCENARIO.toml --result {folder}")
        return named_model(model, args, base, package_path), (
            f"note        {folder} does not record its model (a run of an older uvms): drawing it on {model} as "
            f"given; check that its --arg and --base are the run's")
    recorded = record.load(package_path)
    if model is not None or args or base:
        named = " ".join([model or "the recorded model", *(f"--arg {k}={v}" for k, v in (args or {}).items()),
                          *([f"--base {base}"] if base else [])])
        given = (named_model(model, args, base, package_path) if model is not None else
                 load(record.source, base=base or record.base, args={**record.args, **(args or {})} or None,
                      ee=record.ee or None, package_path=[*package_path, *record.package_path],
                      arm_joints=record.arm_joints))
        check_given_model(record, recorded, given, f"the model given ({named})")
    note = None
    if record.changed_since(recorded):
        note = (f"note        the files of {record.source} changed after the run (the URDF differs from the recorded "
                f"one): drawing the run on them as they are now")
    return recorded, note
