"""The dynamic sections of a scenario file: ``[plant]``, ``[vehicle_control]`` and ``[excitation]``, frozen
dataclasses whose fields are :func:`~uvms.scenario.spec.keys.key` (as :mod:`uvms.scenario.spec.sections`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

from ...control.gjm import GJM_KINDS
from ...control.settings import ActuatedSettings
from ...dynamics.plant.settings import PLANT_KINDS, PlantSettings
from ...errors import ScenarioError
from .keys import NUMBER, NUMBERS, Section, SettingsSection, key

#: The actuated chain's defaults: [vehicle_control]'s (its keys are ActuatedSettings' fields).
CHAIN = ActuatedSettings()
#: The free-floating plant's defaults: [plant]'s of the same names (PlantSettings' fields).
PLANT = PlantSettings()

#: [plant] types: the kinematic simulation (the vehicle follows momentum exactly, or is actuated), or the
#: free-floating dynamics of uvms.dynamics.plant.plant without (rigid) or with (hydrodynamic) the model's hydrodynamics.
PLANT_TYPES = ("kinematic", *PLANT_KINDS)


@dataclass(frozen=True, kw_only=True)
class PlantSpec(SettingsSection):
    """The ``[plant]`` section of a scenario, checked: the free-floating plant's
    :class:`~uvms.dynamics.plant.settings.PlantSettings` (none on the kinematic plant), and the keys of what drives
    it (``gjm``, ``motor_feedforward`` and ``control_dt``: the GJM controller's; ``thrusters``)."""

    SETTINGS: ClassVar[type] = PlantSettings

    ABOUT: ClassVar[str] = "What is integrated: kinematics (the default), or the free-floating dynamics."
    type: str = key('kinematic', str, allowed=PLANT_TYPES,
        doc="`kinematic`: the solver's velocity integrated; `rigid`: free-floating rigid-body dynamics; "
            "`hydrodynamic`: the same with the model's hydrodynamics (buoyancy, added mass, damping, current)")
    gjm: str = key('rigid', str, allowed=GJM_KINDS,
        doc="the Jacobian the GJM controller inverts: `rigid` (generalized Jacobian), `added_mass` (with added-"
            "mass-augmented inertias) or `fixed_base` (the arm Jacobian, vehicle assumed still)")
    motor_time_constant: float = key(PLANT.motor_time_constant, NUMBER,
        doc="the joint servos' first-order time constant τ [s]")
    motor_feedforward: bool = key(False, bool, doc="invert the servo model (u = w + τ ẇ)")
    control_dt: float = key(0.0, NUMBER,
        doc="controller period [s], a multiple of `simulation.dt`; 0: evaluated at every integrator stage")
    gravity: bool = key(PLANT.gravity, bool, doc="`hydrodynamic`: weight and buoyancy")
    added_mass: bool | None = key(PLANT.added_mass, bool,
        doc="`hydrodynamic`: added mass and its Coriolis term; absent: on")
    damping: bool | None = key(PLANT.damping, bool, doc="`hydrodynamic`: linear and quadratic drag; absent: on")
    current: tuple[float, ...] = key(PLANT.current, NUMBERS,
        doc="constant ocean current [m/s, world ENU]; `[]`: none")
    thrusters: bool = key(False, bool,
        doc="the vehicle is actuated by its thrusters and held by `[vehicle_control]` (needs `type = "
            '"hydrodynamic"` and a floating base)')
    hydrodynamics: str = key(PLANT.hydrodynamics, str,
        doc="a hydrodynamics YAML (e.g. the one `uvms identify` writes) used instead of the model's own, a path "
            'inside the scenario\'s folder; `""`: the model\'s')

    @property
    def settings(self) -> PlantSettings | None:
        """The free-floating plant's settings; None on the kinematic plant (no equations of motion)."""
        return None if self.type == "kinematic" else super().settings


@dataclass(frozen=True, kw_only=True)
class VehicleControlSpec(SettingsSection):
    """The ``[vehicle_control]`` section of a scenario, checked: the actuated chain's
    :class:`~uvms.control.settings.ActuatedSettings`."""

    SETTINGS: ClassVar[type] = ActuatedSettings

    ABOUT: ClassVar[str] = (
        "The actuated vehicle (`plant.thrusters = true`): velocity and pose loops, thrust allocation, arm "
        "coordination. See *Bring your own ROV* for the gains.")
    kp: float | tuple[float, ...] | None = key(None, (int, float, list),
        doc="proportional gains of the velocity loop [N s/m, N m s/rad], one or 6 (body FLU); absent: kp = 2 ζ ω "
            "M_ii from `bandwidth`, `damping_ratio` and the vehicle's inertia M_ii (rigid body + added mass)")
    ki: float | tuple[float, ...] | None = key(None, (int, float, list),
        doc="integral gains [N/m, N m/rad], one or 6; absent: ki = ω² M_ii. The integral stops on an axis the "
            "thrusters cannot give (anti-windup)")
    bandwidth: float | tuple[float, ...] = key(CHAIN.bandwidth, (int, float, list),
        doc="closed-loop bandwidth ω of the velocity loop per body axis [rad/s], one or 6")
    damping_ratio: float | tuple[float, ...] = key(CHAIN.damping_ratio, (int, float, list),
        doc="damping ratio ζ of the velocity loop per body axis, one or 6")
    pose_gains: float | tuple[float, ...] = key(CHAIN.pose_gains, (int, float, list),
        doc="pose loop gains [1/s], one or 6")
    max_speed: float | tuple[float, ...] = key(CHAIN.max_speed, (int, float, list),
        doc="bound of the pose loop's velocity reference [m/s, rad/s], one or 6")
    priorities: tuple = key((), list,
        doc='allocation priority, highest group first, e.g. `[["roll", "pitch", "yaw", "z"], ["x", "y"]]`; `[]`: '
            "one group of all six axes")
    coordination: bool = key(CHAIN.coordination, bool,
        doc="solve the arm again with the measured vehicle velocity, so it takes up the vehicle's lag and drift")
    arm_feedforward: bool = key(CHAIN.arm_feedforward, bool,
        doc="feed the arm's reaction into the vehicle loop's model feedforward")
    acceleration_feedforward: bool = key(CHAIN.acceleration_feedforward, bool,
        doc="feed the reference's acceleration (the rate of the vehicle's velocity reference, low-passed over "
            "0.1 s) through the model's inertia into the vehicle loop")
    servo_compensation: bool = key(CHAIN.servo_compensation, bool,
        doc="command the arm's servos so that they reach the asked rate by the end of the control step (their "
            "first-order lag inverted over the step)")
    disturbance_time_constant: float = key(CHAIN.disturbance_time_constant, NUMBER,
        doc="the disturbance observer's time constant T [s]: the wrench the model does not know (an unmodelled "
            "current, a wrong added mass) estimated from the measured acceleration's mismatch, low-passed over T, "
            "and fed forward; 0: none (the integral alone learns it)")
    tightening: bool = key(CHAIN.tightening, bool,
        doc="move each enforced `[[inequalities]]` bound inward, for the solver, by its measured tracking error: the"
            " shortfall of the measured value against what the asked velocity predicted over each step, summed and "
            "decaying at the objective's gain (at most its band); false: the nominal bounds")
    knows_current: bool = key(CHAIN.knows_current, bool,
        doc="the controller's model includes `plant.current`; false: the integral learns it")
    saturation_feedback: bool = key(CHAIN.saturation_feedback, bool,
        doc="bound the vehicle's part of the next reference by what the allocation achieved")

    def settings_values(self) -> dict[str, Any]:
        """The actuated chain's settings (:func:`uvms.control.station.actuated_control`): numbers as floats, lists
        as tuples; ActuatedSettings checks the priorities."""
        values = super().settings_values()
        values["disturbance_time_constant"] = float(values["disturbance_time_constant"])
        return values


@dataclass(frozen=True, kw_only=True)
class ExcitationSpec(Section):
    """The ``[excitation]`` section of a scenario, checked."""

    ABOUT: ClassVar[str] = (
        "Open-loop thrust excitation (`plant.thrusters = true` and `wrench` given): the thrusters get sat(B⁺ "
        "τ(t)), τ(t) a multi-sine body wrench; `[vehicle_control]` is not used. A run whose commands would exceed"
        " the thrusters' limits is refused.")
    wrench: tuple[float, ...] = key((), NUMBERS,
        doc="RMS of the multi-sine per body axis x, y, z, roll, pitch, yaw [N, N m]; 0: the axis not excited; "
            "`[]`: no excitation")
    highest: float = key(0.5, NUMBER,
        doc="the highest frequency [Hz]; the axes interleave on the grid highest/(6 components), 2 highest/(6 "
            "components), … so no two share a frequency")
    components: int = key(8, int, doc="sines per axis")
    seed: int = key(0, int,
        doc="0: Schroeder's phases (low peaks); another integer: phases drawn uniformly from this seed")
    arm: tuple[float, ...] = key((), NUMBERS,
        doc="amplitude per arm joint [rad or m] of a sum of sines about the start; `[]`: the arm held")
    arm_period: float = key(20.0, NUMBER, doc="the first joint's period [s]; joint j's is arm_period / (1 + 0.37 j)")


#: [plant] keys that only a dynamic plant (type rigid or hydrodynamic) uses.
DYNAMIC_KEYS = ("gjm", "motor_feedforward", "control_dt", "gravity", "added_mass", "damping", "current", "thrusters",
                "hydrodynamics")


def check_plant(spec: Any, origin: str) -> None:
    """Refuse a ``[plant]`` and the sections it drives that do not go together (one line each: why, and what works);
    what needs the model (its base, its thrusters) is checked where the plant is built on it.

    Raises:
        ScenarioError: a sequence scenario with inequalities or a dynamic plant; a dynamic plant's key on the
            kinematic one; ``[vehicle_control]`` without thrusters, ``[excitation]`` without its wrench and thrusters;
            what the plant's controller cannot do (:func:`check_actuated`, :func:`check_passive`).
    """
    plant = spec.plant
    try:
        if spec.phases:
            if spec.inequalities:
                raise ScenarioError("[[inequalities]] need a [task] and a [trajectory]; a sequence scenario "
                                    "([[phases]]) has neither")
            if plant.type != "kinematic":
                raise ScenarioError("a sequence scenario ([[phases]]) runs on the kinematic plant only; "
                                    "remove [plant] or set plant.type = 'kinematic'")
        given = spec.vehicle_control.changed()
        if given and not plant.thrusters:
            raise ScenarioError(f"vehicle_control.{given[0]} needs plant.thrusters = true (an actuated vehicle); "
                                f"without thrusters the vehicle moves by momentum conservation or as commanded")
        check_excitation(spec)
        if plant.type == "kinematic":
            unused = plant.changed(DYNAMIC_KEYS)
            if unused:
                raise ScenarioError(f"plant.{unused[0]} needs a dynamic plant: the kinematic one moves the vehicle by "
                                    f"momentum conservation (solver.free_floating) or as commanded; set plant.type = "
                                    f"'rigid' or 'hydrodynamic'")
            return
        if plant.thrusters and spec.controller.type != "mpc":  # the MPC checks its own (check_controller)
            check_actuated(spec)
        if not plant.thrusters:
            check_passive(spec)
    except ScenarioError as exc:
        raise ScenarioError(f"{origin}: {exc}") from None


def check_excitation(spec: Any) -> None:
    """[excitation] keys need excitation.wrench and plant.thrusters = true (they would do nothing); with both, the
    vehicle is driven open loop: [vehicle_control] and [[inequalities]] are refused."""
    given, section = spec.excitation.changed(), spec.excitation
    needs = (("excitation.wrench (6 RMS values [N, N m])", section.wrench),
             ("plant.thrusters = true", spec.plant.thrusters))
    missing = [need for need, present in needs if not present]
    if given and missing:
        raise ScenarioError(f"excitation.{given[0]} needs {' and '.join(missing)}: the excitation drives the "
                            f"vehicle's thrusters")
    if not (section.wrench and spec.plant.thrusters):
        return
    unused = spec.vehicle_control.changed()
    if unused or spec.inequalities:
        what = f"vehicle_control.{unused[0]}" if unused else "[[inequalities]]"
        raise ScenarioError(f"{what} is not used by an excitation ([excitation] wrench): the vehicle is driven open "
                            f"loop; remove it, or remove excitation.wrench for the closed-loop chain")
    if not section.arm_period > 0:
        raise ScenarioError(f"excitation.arm_period must be > 0 s, got {section.arm_period:g}")


def check_actuated(spec: Any) -> None:
    """Refuse what is meaningless on an actuated vehicle (plant.thrusters = true)."""
    plant, solver = spec.plant, spec.solver
    if plant.type != "hydrodynamic":
        raise ScenarioError(f"plant.thrusters = true needs plant.type = 'hydrodynamic' (thrusters push against "
                            f"water), got {plant.type!r}")
    if solver.free_floating:
        raise ScenarioError("solver.free_floating = true leaves the vehicle passive (momentum conservation), but "
                            "plant.thrusters = true actuates it: the solver's vehicle part is the vehicle "
                            "controller's setpoint; remove solver.free_floating (or plant.thrusters for a passive "
                            "vehicle)")
    if isinstance(solver.gain, tuple):
        raise ScenarioError("plant.thrusters = true: solver.gain is one number (K [1/s] of every level; the levels "
                            "are the inequalities, the vehicle's pose objective and the task)")
    if spec.vehicle.changed():
        raise ScenarioError("plant.thrusters = true: the vehicle holds its station by the vehicle controller's pose "
                            "objective (vehicle_control.pose_gains, max_speed), not a [vehicle] task; remove "
                            "[vehicle]")
    if plant.motor_feedforward or plant.control_dt:
        raise ScenarioError("plant.motor_feedforward and plant.control_dt are the GJM controller's; the actuated "
                            "chain runs its controller once per simulation.dt")


def check_passive(spec: Any) -> None:
    """A dynamic plant without thrusters leaves the vehicle passive: the GJM controller (amundsen2018 eq. 4-8) on
    solver.method drives the arm. Refused: free_floating off, a [vehicle] task, solver.alpha or enforce_limits, a gain
    that is not K on the position error, a control_dt that is not a multiple of simulation.dt."""
    section, solver = spec.plant, spec.solver
    passive = f"plant.type = {section.type!r} without thrusters leaves the vehicle passive (no actuators)"
    if not solver.free_floating:
        raise ScenarioError(f"{passive}: the solver cannot command its velocity; set solver.free_floating = true "
                            f"(the joints through the generalized Jacobian, plant.gjm), plant.thrusters = true "
                            f"(an actuated vehicle) or plant.type = 'kinematic'")
    if spec.vehicle.changed(("velocities", "heading", "depth")):
        raise ScenarioError(f"{passive}: a [vehicle] task cannot be followed; remove it (solver.method = "
                            f"{solver.method!r} then prioritizes the task alone) or set plant.thrusters = true")
    if solver.alpha or solver.enforce_limits:
        raise ScenarioError("solver.alpha and solver.enforce_limits are not supported with a dynamic plant; keep the "
                            "joints inside their limits with an [[inequalities]] table of type 'joint_limits' and "
                            "solver.method = 'set_based' or 'hqp'")
    if isinstance(solver.gain, tuple) and len(solver.gain) != 3:
        raise ScenarioError(f"solver.gain with a dynamic plant is K on the position error: one number or 3 "
                            f"(x, y, z) [1/s], got {list(solver.gain)!r}")
    control_dt, dt = float(section.control_dt), float(spec.simulation.dt)
    ratio = control_dt / dt
    if control_dt < 0 or (control_dt > 0 and (ratio < 1 - 1e-9 or abs(ratio - round(ratio)) > 1e-6)):
        raise ScenarioError(f"plant.control_dt must be 0 (continuous controller) or a multiple of simulation.dt = "
                            f"{dt:g} s, got {control_dt:g}")
