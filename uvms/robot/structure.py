"""What a Pinocchio model's structure says before it is a Robot: the kind of base, the joints as uvms shows
them, the default end effectors."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin


@dataclass(frozen=True)
class JointInfo:
    """One joint of the model, as `uvms info` shows it."""

    name: str
    kind: str  # Pinocchio short name, e.g. "JointModelRZ"
    nq: int
    nv: int
    idx_q: int
    idx_v: int
    lower: np.ndarray  # (nq,) [rad or m]
    upper: np.ndarray  # (nq,)
    is_vehicle: bool


def base_type_of(model: pin.Model) -> str:
    """"floating", "planar" or "fixed", from the first joint of a Pinocchio model."""
    if model.njoints > 1 and model.parents[1] == 0:
        shortname = model.joints[1].shortname()
        if shortname == "JointModelFreeFlyer":
            return "floating"
        if shortname == "JointModelPlanar":
            return "planar"
    return "fixed"


def default_end_effectors(model: pin.Model) -> list[str]:
    """Frames named ``ee`` or ``*_ee``; otherwise the body frames of the leaf links."""
    names = [frame.name for frame in model.frames]
    named = [n for n in names if n == "ee" or n.endswith("_ee")]
    if named:
        return named
    parents = {model.frames[i].parentFrame for i in range(len(model.frames))}
    leaves = [
        frame.name for i, frame in enumerate(model.frames)
        if frame.type == pin.FrameType.BODY and i not in parents and frame.name != "world"
    ]
    return leaves[-1:] if leaves else [model.frames[-1].name]
