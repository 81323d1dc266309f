"""The lift and drag of one fin, as the simulator plugins compute them (the equations of their sources, in numpy).

uuv_simulator (``uuv_gazebo_plugins/src/FinPlugin.cc`` and ``LiftDragModel.cc``): the fin link's velocity through
the water (its origin's, minus the current) is projected on the link's x-y plane (the plane normal to the span, the
link's z axis) and written in the link frame, v_L = (v_x, v_y, 0); then, with angle = atan2(v_y, v_x) folded into
[-pi/2, pi/2] (v_L negated when folded) and u = ``|v_L|``:

* ``Quadratic`` (Engelhardtsen 2007): lift = lift_constant angle u^2, drag = drag_constant angle^2 u^2;
* ``TwoLines`` (Gazebo 7's LiftDragPlugin): alpha = angle + a0 folded into [-pi/2, pi/2], q = rho u^2 / 2,
  cl = cla alpha and cd = cda alpha below the stall, beyond it cl = cla alpha_stall + cla_stall (alpha -
  alpha_stall) and cd likewise; lift = cl q area, drag = cd q area. As the source writes it, the branch alpha <
  -alpha_stall takes cda_stall for the lift slope, and cd is not made positive (a negative alpha gives a negative
  drag, a push forward); uvms reproduces both.

Both give F_L = lift (-(z x v_L) / ``|z x v_L|``) + drag (-v_L / ``|v_L|``) with the unfolded v_L, applied at the link's
centre of mass (``AddRelativeForce``); a zero vector stays zero (``ignition::math::Vector3::Normalize``).

Gazebo Sim (``gz-sim src/systems/lift_drag/LiftDrag.cc``, ``LiftDragPrivate::Update``): the velocity of the centre
of pressure v = v_link + w x R cp (minus a Wind entity's velocity, none under water: the ocean current is not
subtracted); no force when ``|v|`` <= 0.01 m/s, nor when ``forward . v <= 0`` unless ``reversible``. With f = R
forward, u = R upward (or, ``radial_symmetry``, f x (f x v) normalized), s = f x u normalized, sin(sweep) = s . v /
``|v|``, v_p = v - (v . s) s the velocity in the lift-drag plane, the lift direction l = s x v_p normalized and the
drag direction -v_p normalized: alpha = a0 +- acos(l . u) (+ when l . f >= 0) folded into [-pi/2, pi/2];
q = rho ``|v_p|``^2 / 2; cl = cla alpha cos^2(sweep) below the stall, (cla alpha_stall + cla_stall (alpha -
alpha_stall)) cos^2(sweep) beyond (kept >= 0; and mirrored, <= 0, below -alpha_stall), plus control_joint_rad_to_cl
delta with a control joint at delta; cd likewise with cda and cda_stall, then ``|cd|``; cm likewise with cma, cma_stall,
plus cm_delta delta. Force lift + drag = (cl l + cd (-v_p/``|v_p|``)) q area at the centre of pressure, moment cm q area
s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Speed [m/s] at or below which Gazebo Sim's LiftDrag applies no force (``vel.Length() <= 0.01``).
GZ_MIN_SPEED = 0.01


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b of two (3,) vectors: numpy's cross is ten times slower on them (the fins' lift and drag per stage)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


@dataclass(frozen=True)
class UUVQuadratic:
    """uuv_simulator's ``Quadratic`` lift and drag: lift_constant [N s^2/(m^2 rad)], drag_constant [N s^2/(m^2
    rad^2)]."""

    lift_constant: float
    drag_constant: float


@dataclass(frozen=True)
class UUVTwoLines:
    """uuv_simulator's ``TwoLines`` lift and drag: area [m^2], fluid_density [kg/m^3], a0 and alpha_stall [rad],
    cla, cla_stall, cda, cda_stall [1/rad]."""

    area: float
    fluid_density: float
    a0: float
    alpha_stall: float
    cla: float
    cla_stall: float
    cda: float
    cda_stall: float


@dataclass(frozen=True)
class GzLiftDrag:
    """Gazebo Sim's LiftDrag system's parameters (their tags; the defaults of ``LiftDrag.cc``).

    Attributes: a0, alpha_stall [rad]; cla, cda, cma, cla_stall, cda_stall, cma_stall [1/rad]; cm_delta and
    control_joint_rad_to_cl [1/rad] (used with a control joint); rho [kg/m^3] (``air_density``, the fluid's);
    area [m^2]; cp (3,) [m] centre of pressure in the link frame; forward, upward (3,) unit, link frame;
    radial_symmetry, reversible; control_joint: whether a ``<control_joint_name>`` is given.
    """

    a0: float = 0.0
    cla: float = 1.0
    cda: float = 0.01
    cma: float = 0.0
    alpha_stall: float = math.pi / 2
    cla_stall: float = 0.0
    cda_stall: float = 1.0
    cma_stall: float = 0.0
    cm_delta: float = 0.0
    rho: float = 1.2041
    area: float = 1.0
    cp: tuple[float, float, float] = (0.0, 0.0, 0.0)
    forward: tuple[float, float, float] = (1.0, 0.0, 0.0)
    upward: tuple[float, float, float] = (0.0, 0.0, 1.0)
    radial_symmetry: bool = False
    reversible: bool = False
    control_joint_rad_to_cl: float = 4.0
    control_joint: bool = False


def _unit(vector: np.ndarray) -> np.ndarray:
    """``vector`` normalized; a zero vector stays zero (ignition/gz math's Normalize)."""
    norm = float(np.linalg.norm(vector))
    return vector / norm if norm > 0.0 else vector


def _fold(angle: float) -> float:
    """An angle [rad] folded into [-pi/2, pi/2] by steps of pi (the plugins' ``while (fabs(alpha) > pi/2)``)."""
    while abs(angle) > 0.5 * math.pi:
        angle = angle - math.pi if angle > 0 else angle + math.pi
    return angle


def uuv_force(model: UUVQuadratic | UUVTwoLines, velocity: np.ndarray) -> np.ndarray:
    """The force (3,) [N] in the fin link's frame for its velocity (3,) [m/s] through the water in that frame
    (``LiftDragQuadratic::compute`` / ``LiftDragTwoLines::compute`` after FinPlugin's projection: z dropped)."""
    v = np.array([velocity[0], velocity[1], 0.0])
    angle = math.atan2(v[1], v[0])
    if angle > 0.5 * math.pi:
        angle -= math.pi
    elif angle < -0.5 * math.pi:
        angle += math.pi
    u2 = float(v @ v)  # |velL|^2, the same folded or not
    if isinstance(model, UUVQuadratic):
        lift = model.lift_constant * angle * u2
        drag = model.drag_constant * angle * angle * u2
    else:
        alpha = _fold(angle + model.a0)
        q = 0.5 * model.fluid_density * u2
        if alpha > model.alpha_stall:
            cl = model.cla * model.alpha_stall + model.cla_stall * (alpha - model.alpha_stall)
            cd = model.cda * model.alpha_stall + model.cda_stall * (alpha - model.alpha_stall)
        elif alpha < -model.alpha_stall:  # the source's slopes: cda_stall for the lift too
            cl = -model.cla * model.alpha_stall + model.cda_stall * (alpha + model.alpha_stall)
            cd = -model.cda * model.alpha_stall + model.cda_stall * (alpha + model.alpha_stall)
        else:
            cl, cd = model.cla * alpha, model.cda * alpha
        lift, drag = cl * q * model.area, cd * q * model.area
    lift_direction = -_unit(np.array([-v[1], v[0], 0.0]))  # -(z x v)
    return lift * lift_direction + drag * _unit(-v)


def _stalled(slope: float, stall_slope: float, alpha: float, stall: float, sweep: float, sign_kept: bool) -> float:
    """cl, cd or cm of Gazebo Sim's LiftDrag: linear below the stall, the stall slope beyond, times cos^2(sweep)."""
    if alpha > stall:
        value = (slope * stall + stall_slope * (alpha - stall)) * sweep
        return max(0.0, value) if sign_kept else value
    if alpha < -stall:
        value = (-slope * stall + stall_slope * (alpha + stall)) * sweep
        return min(0.0, value) if sign_kept else value
    return slope * alpha * sweep


def gz_wrench(model: GzLiftDrag, rotation: np.ndarray, velocity: np.ndarray, angular: np.ndarray,
              angle: float) -> tuple[np.ndarray, np.ndarray]:
    """Gazebo Sim's LiftDrag on one link: (force (3,) [N], torque (3,) [N m] about the link origin), in the axes of
    ``rotation`` (the link's orientation, (3, 3)) and of the link origin's ``velocity`` (3,) [m/s] and the
    ``angular`` velocity (3,) [rad/s]; ``angle`` [rad] the control joint's position (used with a control joint)."""
    zero = np.zeros(3)
    cp = rotation @ np.asarray(model.cp, dtype=float)
    vel = velocity + _cross(angular, cp)
    speed = float(np.linalg.norm(vel))
    if speed <= GZ_MIN_SPEED:
        return zero, zero
    unit_velocity = vel / speed
    forward = rotation @ _unit(np.asarray(model.forward, dtype=float))
    if not model.reversible and forward @ vel <= 0.0:
        return zero, zero
    if model.radial_symmetry:
        upward = _unit(_cross(forward, _cross(forward, unit_velocity)))
    else:
        upward = rotation @ _unit(np.asarray(model.upward, dtype=float))
    spanwise = _unit(_cross(forward, upward))
    sin_sweep = float(np.clip(spanwise @ unit_velocity, -1.0, 1.0))
    sweep = 1.0 - sin_sweep * sin_sweep  # cos^2 of the sweep angle
    in_plane = vel - (vel @ spanwise) * spanwise
    drag_direction = -_unit(in_plane)
    lift_direction = _unit(_cross(spanwise, in_plane))
    cos_alpha = float(np.clip(lift_direction @ upward, -1.0, 1.0))
    alpha = model.a0 + math.acos(cos_alpha) if lift_direction @ forward >= 0.0 else model.a0 - math.acos(cos_alpha)
    alpha = _fold(alpha)
    q = 0.5 * model.rho * float(in_plane @ in_plane)
    cl = _stalled(model.cla, model.cla_stall, alpha, model.alpha_stall, sweep, True)
    cd = abs(_stalled(model.cda, model.cda_stall, alpha, model.alpha_stall, sweep, False))
    cm = _stalled(model.cma, model.cma_stall, alpha, model.alpha_stall, sweep, True)
    if model.control_joint:
        cl += model.control_joint_rad_to_cl * angle
        cm += model.cm_delta * angle
    force = (cl * lift_direction + cd * drag_direction) * q * model.area
    torque = cm * q * model.area * spanwise + _cross(cp, force)
    force, torque = np.nan_to_num(force, nan=0.0, posinf=0.0, neginf=0.0), np.nan_to_num(torque, nan=0.0,
                                                                                           posinf=0.0, neginf=0.0)
    return force, torque
