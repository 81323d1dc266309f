"""The dynamic sections of a scenario file: ``[plant]``, ``[vehicle_control]`` and ``[excitation]``, frozen
dataclasses whose fields are :func:`~uvms.scenario.spec.keys.key` (as :mod:`uvms.scenario.spec.sections`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

from ...control.gjm import GJM_KINDS
from ...control.settings import ActuatedSettings
from ...errors import ScenarioError, UVMSError
from .keys import NUMBER, NUMBERS, Section, key

#: The actuated chain's defaults: [vehicle_control]'s (its keys are ActuatedSettings' fields).
CHAIN = ActuatedSettings()

#: [plant] types: the kinematic simulation (the vehicle follows momentum exactly, or is actuated), or the
#: free-floating dynamics of uvms.dynamics.plant.plant without (rigid) or with (hydrodynamic) the model's hydrodynamics.
PLANT_TYPES = ("kinematic", "rigid", "hydrodynamic")


@dataclass(frozen=True, kw_only=True)
class PlantSpec(Section):
    """The ``[plant]`` section of a scenario, checked."""

    ABOUT: ClassVar[str] = "What is integrated: kinematics (the default), or the free-floating dynamics."
    type: str = key('kinematic', str, allowed=PLANT_TYPES,
        doc="`kinematic`: the solver's velocity integrated; `rigid`: free-floating rigid-body dynamics; "
            "`hydrodynamic`: the same with the model's hydrodynamics (buoyancy, added mass, damping, current)")
    gjm: str = key('rigid', str, allowed=GJM_KINDS,
        doc="the Jacobian the GJM controller inverts: `rigid` (generalized Jacobian), `added_mass` (with added-"
            "mass-augmented inertias) or `fixed_base` (the arm Jacobian, vehicle assumed still)")
    motor_time_constant: float = key(0.1, NUMBER, doc="the joint servos' first-order time constant τ [s]")
    motor_feedforward: bool = key(False, bool, doc="invert the servo model (u = w + τ ẇ)")
    control_dt: float = key(0.0, NUMBER,
        doc="controller period [s], a multiple of `simulation.dt`; 0: evaluated at every integrator stage")
    gravity: bool = key(False, bool, doc="`hydrodynamic`: weight and buoyancy")
    added_mass: bool | None = key(None, bool, doc="`hydrodynamic`: added mass and its Coriolis term; absent: on")
    damping: bool | None = key(None, bool, doc="`hydrodynamic`: linear and quadratic drag; absent: on")
    current: tuple[float, ...] = key((), NUMBERS, doc="constant ocean current [m/s, world ENU]; `[]`: none")
    thrusters: bool = key(False, bool,
        doc="the vehicle is actuated by its thrusters and held by `[vehicle_control]` (needs `type = "
            '"hydrodynamic"` and a floating base)')
    hydrodynamics: str = key('', str,
        doc="a hydrodynamics YAML (e.g. the one `uvms identify` writes) used instead of the model's own, a path "
            'inside the scenario\'s folder; `""`: the model\'s')


@dataclass(frozen=True, kw_only=True)
class VehicleControlSpec(Section):
    """The ``[vehicle_control]`` section of a scenario, checked."""

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

    @classmethod
    def from_table(cls, given: Any, name: str, origin: str) -> Section:
        """The section (:meth:`Section.from_table`), its settings made once (:attr:`settings`) so that what they
        refuse is said where the file is read."""
        section = super().from_table(given, name, origin)
        try:
            section.settings  # noqa: B018 - ActuatedSettings checks the priorities
        except UVMSError as exc:
            raise ScenarioError(f"{origin}: {name}.{exc}") from None
        return section

    @property
    def settings(self) -> ActuatedSettings:
        """The actuated chain's settings of this section (:func:`uvms.control.station.actuated_control`): the one
        place a scenario's [vehicle_control] becomes them (numbers as floats, lists as tuples).

        Raises:
            SolverInputError: priorities that are not groups of wrench axes.
        """
        values = {name: getattr(self, name) for name in ActuatedSettings.names()}
        values["disturbance_time_constant"] = float(values["disturbance_time_constant"])
        return ActuatedSettings(**values)


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
