"""The sections of a scenario file besides the dynamic ones: one frozen dataclass per section (and per
``[[phases]]`` table), each field a :func:`~uvms.scenario.spec.keys.key` (type, default, allowed values, bound,
meaning: the one source of the reader's checks and of the docs' scenario reference)."""

from __future__ import annotations

from dataclasses import MISSING, dataclass, fields
from typing import Any, ClassVar

from ...solvers import SOLVERS
from ...trajectory.settings import LAWS, TRAJECTORY_TYPES, TrajectorySettings
from .keys import NUMBER, NUMBERS, REQUIRED, Bound, Section, SettingsSection, key

#: Defaults of [outputs] position_tolerance [m] and orientation_tolerance [rad]: a run whose task error exceeds
#: them is reported as not meeting its task (a terminal warning, metrics.json "verdict"). 1 cm and 1 degree: far
#: above what closed-loop kinematic control reaches (1e-10 m), and an error a user sees in a figure.
DEFAULT_POSITION_TOLERANCE = 0.01
DEFAULT_ORIENTATION_TOLERANCE = 0.0175
#: solver.method values: the solvers registered in uvms.solvers.SOLVERS (a live view: a method registered later is
#: valid).
SOLVER_METHODS = SOLVERS.keys()
#: [trajectory]'s defaults: the trajectory settings' (its keys are TrajectorySettings' fields).
TRAJECTORY = {item.name: item.default for item in fields(TrajectorySettings) if item.default is not MISSING}


@dataclass(frozen=True, kw_only=True)
class LabelSpec(Section):
    """The ``[scenario]`` section of a scenario, checked."""

    ABOUT: ClassVar[str] = "A label. Optional."
    name: str = key('', str,
        doc="the run's name and default output folder `out/<name>`; a plain name (letters, digits, `.`, `_`, `-`,"
            " at most 128 characters). Default: the file's stem")
    description: str = key('', str, doc="one line printed with the run")


@dataclass(frozen=True, kw_only=True)
class ModelSpec(Section):
    """The ``[model]`` section of a scenario, checked."""

    ABOUT: ClassVar[str] = "The model the scenario runs. Required."
    path: str = key(REQUIRED, str,
        doc="a `.urdf`/`.xacro` file (relative to the scenario file) or a shipped model name (`hoang2011`, "
            "`bluerov2_alpha5`, ...)")
    base: str = key('', str, allowed=('', 'floating', 'planar', 'fixed'),
        doc='override the base rule: `floating`, `planar` or `fixed`; `""` keeps what the file and the rule say '
            "(see *Bring your own ROV*)")
    ee: str = key('', str,
        doc='the end-effector frame; `""`: the rule of `uvms.load` (a frame named `end_effector`, `tool`, `tcp` '
            "or `ee`, else the arm's last leaf link)")
    args: dict[str, Any] = key({}, dict,
        doc="xacro args, `{name = value}`: numbers, `true`/`false` or plain names; `--set model.args.l1=0.6` "
            "overrides one")
    package_path: tuple = key((), list,
        doc="folders of ROS packages for `$(find pkg)` and `package://pkg/...`, relative to the scenario file; "
            "searched before `ROS_PACKAGE_PATH`")
    arm_joints: tuple | None = key(None, list,
        doc="the joints that move besides the vehicle; every other joint is frozen (held at 0, or at its limit "
            "nearest to 0). Absent: the rule of `uvms.load` (propellers, sensor mounts and zero-range joints "
            "frozen, mimic chains composed)")


@dataclass(frozen=True, kw_only=True)
class TaskSpec(Section):
    """The ``[task]`` section of a scenario, checked."""

    ABOUT: ClassVar[str] = "What the end effector must do."
    frame: str = key('', str, doc='the controlled frame; `""`: the model\'s first end effector')
    frames: tuple = key((), list,
        doc="sequence scenarios (`[[phases]]`): the controlled frames, positions only, 3 rows each")
    axes: tuple = key((), list,
        doc="the task axes among `x y z roll pitch yaw`; `[]`: all six (planar base: `x y yaw`)")
    orientation_error: str = key('log', str, allowed=('log', 'euler'),
        doc="`log`: the SO(3) logarithm; `euler`: the roll-pitch-yaw difference (hoang2011)")


@dataclass(frozen=True, kw_only=True)
class TrajectorySpec(SettingsSection):
    """The ``[trajectory]`` section of a scenario, checked: the trajectory layer's
    :class:`~uvms.trajectory.settings.TrajectorySettings`."""

    SETTINGS: ClassVar[type] = TrajectorySettings

    ABOUT: ClassVar[str] = (
        "The desired motion of `task.frame`, in world axes (ENU). Required unless the scenario has `[[phases]]`.")
    type: str = key(TRAJECTORY['type'], str, allowed=TRAJECTORY_TYPES,
        doc="`circle`; `line`; `pose` (a line and the SO(3) geodesic between two orientations); `ramps` "
            "(piecewise-linear velocity: rest → `velocity` in `accel_time`, cruise, back to rest at `duration`); "
            "`hold` (the frame kept where it starts: station keeping)")
    start: tuple[float, ...] = key(TRAJECTORY['start'], NUMBERS,
        doc="start point [m]; `[]`: where the frame is at the initial configuration")
    center: tuple[float, ...] = key(TRAJECTORY['center'], NUMBERS, doc="circle centre [m], absolute")
    center_offset: tuple[float, ...] = key(TRAJECTORY['center_offset'], NUMBERS,
        doc="circle centre [m] relative to `start`")
    normal: tuple[float, ...] = key(TRAJECTORY['normal'], NUMBERS, doc="the normal of the circle's plane")
    end: tuple[float, ...] = key(TRAJECTORY['end'], NUMBERS, doc="line or pose end point [m], absolute")
    end_offset: tuple[float, ...] = key(TRAJECTORY['end_offset'], NUMBERS,
        doc="line or pose end point [m] relative to `start`")
    orientation: tuple[float, ...] = key(TRAJECTORY['orientation'], NUMBERS,
        doc="constant orientation, roll-pitch-yaw [rad]; `[]`: the frame's initial orientation")
    end_orientation: tuple[float, ...] = key(TRAJECTORY['end_orientation'], NUMBERS,
        doc="`pose`: the orientation at the end, roll-pitch-yaw [rad]")
    law: str = key(TRAJECTORY['law'], str, allowed=LAWS, doc="the time law along the path")
    speed: float = key(TRAJECTORY['speed'], NUMBER,
        doc="trapezoid law: cruise speed [m/s] (the distance is then speed × duration); 0: the path (or its "
            "`laps`) covered in `duration`")
    laps: float = key(TRAJECTORY['laps'], NUMBER,
        bound=Bound(0.0, strict=False, what="laps of the circle; 0: one pass"),
        doc="circle: laps in `duration` (not with `speed`); 0: one pass")
    duration: float = key(REQUIRED, NUMBER, bound=Bound(0.0, strict=True, what="the trajectory's length [s]"),
        doc="length of the motion [s]")
    accel_time: float = key(TRAJECTORY['accel_time'], NUMBER,
        bound=Bound(0.0, strict=False, what="the acceleration time [s]"),
        doc="acceleration (and deceleration) time of the trapezoid or of `ramps` [s]")
    velocity: tuple[float, ...] = key(TRAJECTORY['velocity'], NUMBERS,
        doc="`ramps`: the cruise velocity [m/s, world]")


@dataclass(frozen=True, kw_only=True)
class SolverSpec(Section):
    """The ``[solver]`` section of a scenario, checked."""

    ABOUT: ClassVar[str] = (
        "The velocity solver, run at every step (see *Solvers* in the user guide for when to use which).")
    method: str = key('clik', str, allowed=SOLVER_METHODS,
        doc="`clik` (closed-loop IK, weighted pseudo-inverse), `task_priority`, `kinematic_constraint` "
            "(santos2006's virtual chain), `set_based` (iCAT) and `hqp` (a cascade of QPs) — the last two enforce"
            " `[[inequalities]]`")
    gain: float | tuple[float, ...] = key(1.0, (int, float, list), doc="K [1/s]: one number, or one per task row")
    weights: tuple[float, ...] = key((), NUMBERS,
        doc="W, the diagonal of the weighted pseudo-inverse, one per solved column: nv for `clik` (the vehicle's "
            "pose coordinates, then the arm), n_arm with `free_floating` or a dynamic `[plant]`; `[]`: identity")
    damping: float = key(0.0, NUMBER, bound=Bound(0.0, strict=False, what="the DLS damping"), doc="fixed DLS damping λ")
    damping_epsilon: float = key(
        0.0, NUMBER, bound=Bound(0.0, strict=False, what="the singular-value threshold of the variable damping"),
        doc="variable damping (amundsen2018 eq. 6): the singular-value threshold ε below which damping starts")
    damping_max: float = key(0.0, NUMBER, bound=Bound(0.0, strict=False, what="the largest variable damping"),
        doc="variable damping: the largest damping λ_max")
    alpha: float = key(0.0, NUMBER, doc="the gain α of the joint-limit null-space term (hoang2011 eq. 27); 0: none")
    joint_limit_weights: float | tuple[float, ...] = key(1.0, (int, float, list),
        doc="the weights cᵢ of the joint-limit potential S(q): one number or one per arm joint")
    free_floating: bool = key(False, bool,
        doc="solve with the generalized Jacobian: the vehicle is passive and moves by momentum conservation")
    enforce_limits: bool = key(False, bool, doc="clamp the joints at their limits")
    priority: str = key('robust', str, allowed=('robust', 'classic'),
        doc="`task_priority`: `robust` (singularity-robust) or `classic`")
    eta: float = key(1.0, NUMBER, bound=Bound(0.0, strict=False, what="the weight of the iCAT regularization"),
        doc="`set_based`: weight of the iCAT (I − Q) regularization")
    regularization: float = key(1e-09, NUMBER, bound=Bound(0.0, strict=False, what="the weight of |x|^2 in the QPs"),
        doc="`hqp`: weight of ‖x‖²_W in each level's QP")


@dataclass(frozen=True, kw_only=True)
class VehicleSpec(Section):
    """The ``[vehicle]`` section of a scenario, checked."""

    ABOUT: ClassVar[str] = (
        "The vehicle task of `task_priority` and `kinematic_constraint`, and the vehicle of sequence scenarios.")
    velocities: dict[str, Any] = key({}, dict,
        doc="imposed body velocities `{vx = 0, wz = 0, ...}` (names `vx vy vz wx wy wz`; planar `vx vy wz`) [m/s,"
            " rad/s]")
    heading: float | None = key(None, NUMBER, doc="target world yaw [rad] (ENU, about z up); absent: free")
    depth: float | None = key(None, NUMBER, doc="target world z [m] (floating base); absent: free")
    gain: float = key(1.0, NUMBER, doc="gain of the heading and depth rows [1/s]")
    hold: bool = key(True, bool, doc="sequence scenarios: keep the vehicle at rest")


@dataclass(frozen=True, kw_only=True)
class InitialSpec(Section):
    """The ``[initial]`` section of a scenario, checked."""

    ABOUT: ClassVar[str] = "The configuration at t = 0."
    method: str = key('given', str, allowed=('given', 'optimize'),
        doc="`given`: `base` and `arm` as written; `optimize`: min S(q) such that the frame is at the "
            "trajectory's start, within the joint limits (hoang2011 sec. 2.3)")
    base: tuple[float, ...] = key((), NUMBERS,
        doc="vehicle pose: `[x, y, yaw]` (planar) or `[x, y, z, roll, pitch, yaw]` (floating) [m, rad]; `[]`: "
            "zero")
    arm: tuple | dict[str, float] = key((), (list, dict),
        doc="the arm joints [rad or m]: a list of n_arm numbers in the order `uvms info` prints, or a table "
            "`{joint = value}` whose joints left out start at 0. A list must name every arm joint (every joint "
            "that is not the vehicle's and not frozen)")
    fixed_base: tuple = key((), list,
        doc='`optimize`: vehicle coordinates held at their `base` value (0 where not given), e.g. `["roll", '
            '"pitch"]` keeps the vehicle level')


@dataclass(frozen=True, kw_only=True)
class SimulationSpec(Section):
    """The ``[simulation]`` section of a scenario, checked."""

    ABOUT: ClassVar[str] = "The time loop. Required."
    dt: float = key(REQUIRED, NUMBER, bound=Bound(0.0, strict=True, what="the integration step [s]"),
        doc="integration step [s]")
    duration: float = key(0.0, NUMBER, bound=Bound(0.0, strict=False, what="the run length [s]; 0: the trajectory's"),
        doc="length of the run [s]; 0: the trajectory's `duration` (or the sum of the phases)")
    integrator: str = key('rk4', str, allowed=('euler', 'rk4'),
        doc="`rk4` (Munthe-Kaas on the manifold) or `euler` (explicit, what a fixed-step MATLAB loop does)")


@dataclass(frozen=True, kw_only=True)
class OutputsSpec(Section):
    """The ``[outputs]`` section of a scenario, checked."""

    ABOUT: ClassVar[str] = "What a run writes besides `metrics.json` and `trajectory.csv`/`.npz`."
    figures: bool = key(True, bool, doc="write the PNG figures")
    animation: str = key('', str,
        doc='an animation file name in the run folder (`.gif`, or `.mp4` with ffmpeg); `""`: none')
    position_tolerance: float = key(
        DEFAULT_POSITION_TOLERANCE, NUMBER,
        bound=Bound(0.0, strict=True, what="the largest position error [m] of a run said to meet its task"),
        doc="the largest position error [m] of a run that meets its task (above it: a verdict warning)")
    orientation_tolerance: float = key(
        DEFAULT_ORIENTATION_TOLERANCE, NUMBER,
        bound=Bound(0.0, strict=True, what="the largest orientation error [rad] of a run said to meet its task"),
        doc="the largest orientation error [rad] of a run that meets its task")
    bag: bool = key(False, bool, doc="also write the run as a ROS 2 bag (`bag/`, MCAP); the same as `uvms run --bag`")


@dataclass(frozen=True, kw_only=True)
class StudySpec(Section):
    """The ``[study]`` section of a scenario, checked."""

    ABOUT: ClassVar[str] = "`uvms study`: a Monte Carlo study of this scenario (see the Studies guide)."
    samples: tuple = key((), list,
        doc='the sampled keys of `uvms study` (a Monte Carlo study of this scenario), each a string `"KEY=DIST"`:'
            " DIST is `normal(mu, sigma)`, `normal(mu, sigma, low, high)`, `uniform(a, b)`, `loguniform(a, b)` or"
            " `choice([...])` (see the Studies guide)")
    n: int = key(0, int, doc="the number of trials of `uvms study` (`uvms study -n N` overrides it)")
    seed: int = key(0, int,
        doc="the study's seed: trial k gets `SeedSequence(seed).spawn(n)[k]`; the same seed gives the same table")
    set: tuple = key((), list,
        doc='`--set` strings `"KEY=VALUE"` applied to every trial before its sampled values (e.g. a shorter run, '
            "a fixed trim)")
    method: str = key('random', str, allowed=('random', 'lhs', 'sobol'),
        doc="how the quantiles are drawn: `random` (each trial from its own seed), `lhs` (Latin hypercube) or "
            "`sobol` (scrambled Sobol), through scipy.stats.qmc")


@dataclass(frozen=True, kw_only=True)
class PhaseSpec(Section):
    """The ``[phases]`` table of a scenario, checked."""

    ABOUT: ClassVar[str] = (
        "Sequence scenarios replace `[trajectory]` by an array `[[phases]]`, one table per phase (see "
        "`scenarios/xiang2019_grip.toml`).")
    name: str = key('', str, doc="the phase's label in figures and metrics")
    duration: float = key(REQUIRED, NUMBER, doc="the phase's length [s]")
    offsets: dict[str, Any] = key({}, dict,
        doc="`{frame = [dx, dy, dz]}`: the frame's displacement over the phase [m, world]")
    joints: dict[str, Any] = key({}, dict,
        doc="`{joint = value}`: joint values at the end of the phase [rad or m] (claws)")
    distance: float | None = key(None, NUMBER,
        doc="the distance between the first two `task.frames` at the end of the phase [m]; their targets move "
            "symmetrically")
