"""``uvms info``'s fins and the allocation line: what each fin plugin gives, and which body-wrench directions the
thrusters (and, with speed, the fins) can produce."""

from __future__ import annotations

import warnings

import numpy as np

from ..dynamics.thrusters.fins import Fin, Fins
from ..dynamics.thrusters.lift_drag import GzLiftDrag, UUVQuadratic
from ..errors import UVMSError
from ..robot.robot import Robot


def model_text(fin: Fin) -> str:
    """The fin's lift-and-drag model in one line (its plugin's numbers)."""
    model = fin.model
    if isinstance(model, UUVQuadratic):
        return f"uuv Quadratic lift {model.lift_constant:g} drag {model.drag_constant:g}"
    if isinstance(model, GzLiftDrag):
        control = f", {model.control_joint_rad_to_cl:g}/rad of control joint" if model.control_joint else ""
        return (f"gz LiftDrag cla {model.cla:g} cda {model.cda:g} stall {model.alpha_stall:g} rad, area "
                f"{model.area:g} m^2, rho {model.rho:g}{control} (no ocean current: gz subtracts a wind only)")
    return (f"uuv TwoLines cla {model.cla:g} cda {model.cda:g} stall {model.alpha_stall:g} rad, area "
            f"{model.area:g} m^2, rho {model.fluid_density:g}")


def fin_lines(robot: Robot) -> tuple[list[str], Fins]:
    """The fins of the model (:func:`uvms.dynamics.thrusters.fins.fins_of`): joint, link origin in the base frame, angle
    range, time constant, model; their warnings become lines ("not usable" when their data are wrong)."""
    from ..dynamics.thrusters.fins import fins_of

    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            fins = fins_of(robot)
    except UVMSError as exc:
        return [f"fins        not usable: {' '.join(str(exc).split())}"], Fins()
    if not len(fins):
        return [], fins
    lines = [(f"fins ({len(fins)}) from {fins.source}: joint, link origin [m] (base frame), angle range [rad], time "
              "constant [s], lift and drag")]
    for fin in fins.items:
        motion = f"[{fin.lower:g}, {fin.upper:g}]  {fin.time_constant:g}" if fin.moves else "fixed (no angle)"
        lines.append(f"  {fin.name}  {fin.joint or 'no joint: a fixed lifting surface'}  xyz "
                     f"{np.array2string(fin.position, precision=3, suppress_small=True)}  {motion}  {model_text(fin)}")
    lines += [f"  note: {' '.join(str(warning.message).split())}" for warning in caught]
    return lines, fins
