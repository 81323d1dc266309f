"""An actuated vehicle in the free-floating plant: thrusters and fins with a first-order response and saturation.

The state of :class:`ActuatedPlantSystem` is (q, x) with x = [v (nv,), f (n,), delta (m,)], f the thrusts [N],
delta the fins' angles [rad] (none without fins); its rate is

    q' = v,   v' = plant acceleration under the joint command u and the body wrench B f + w_fins(nu_r, delta),
    f' = (sat(f_cmd) - f) / tau,   sat = clip to [-max_reverse, +max_forward]
    delta' = (sat(delta_cmd) - delta) / tau_fin,   sat = clip to the fin joints' limits

with B (6, n) the allocation matrix (:func:`uvms.dynamics.thrusters.thrusters.allocation_matrix`), w_fins the fins' lift
and drag at the vehicle's velocity through the water nu_r (:class:`uvms.dynamics.thrusters.fins.Fins`), the wrench
applied at the vehicle's base frame (:meth:`uvms.dynamics.plant.plant.Plant.dynamics`). Since the command is clipped
and f moves towards it, f stays inside the bounds (delta likewise). A plant without thrusters keeps its state (q, v):
:class:`uvms.dynamics.plant.plant.PlantSystem`. :class:`ActuatedPlant` (plant + thrusters) builds the system
(:meth:`ActuatedPlant.system`).

The controller (:class:`uvms.control.base.Controller`) is digital: asked ``command(State(q, v, f, delta), t)``
once per step at the step's start, its Command's ``arm``, ``thrust`` and ``fins`` held over the integrator's
stages, as a vehicle computer at 1/dt does; its state (integrators) advances per call.

Energy balance (no current): d(kinetic + potential)/dt = thrust power (B f . nu_base = sum_i f_i (B_i . nu)) + fin
power (w_fins . nu_base, <= 0 at rest angles) + motor power (tau_m . qd_m) + damping power (sum_l f_D,l . nu_l <= 0).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from ...errors import ConfigurationError, StepCountError, UVMSError
from ...numerics._kernels import Kernel
from ..thrusters.fins import Fins, fins_of
from ..thrusters.thrusters import Thrusters, allocation_matrix, thrusters_of
from .command import Command, Controller, State, refuse_fields
from .plant import Plant
from .system import PlantDynamics, PlantSystem, check_finite, check_finite_state, plant_row

#: What an actuated plant applies of a Command (no arm: zero; no fins: none).
TAKEN = ("arm", "thrust", "fins")


class ActuatedPlant:
    """A plant whose vehicle has thrusters: B (6, n), bounds (n,) and time constants (n,) on the plant's vehicle.

    What :func:`uvms.sim.loop.simulate` integrates with the state (q, [v, f]) under a digital vehicle controller
    (:meth:`system`).

    Args:
        plant: the Plant (its robot gives the frames; its current, damping, gravity apply); thrusters: their data.
        thrusts0: (n,) [N] the thrusts at t = 0, within the bounds (None: zero).
        fins: the vehicle's fins (:func:`uvms.dynamics.thrusters.fins.fins_of`; None: none), at their rest angles
            at t = 0.

    Raises:
        ModelCheckError: a thruster on an arm link, a fixed base.
        UVMSError: no thrusters.
        ConfigurationError: thrusts0 of the wrong size, non-finite or outside the bounds.
    """

    def __init__(self, plant: Plant, thrusters: Thrusters, *, thrusts0: np.ndarray | None = None,
                 fins: Fins | None = None) -> None:
        if len(thrusters) == 0:
            raise UVMSError(f"{thrusters.source}: no thrusters to actuate the vehicle with")
        self.plant, self.robot, self.model = plant, plant.robot, plant.model
        self.thrusters = thrusters
        self.matrix = allocation_matrix(plant.robot, thrusters)  # (6, n)
        self.lower, self.upper = thrusters.lower, thrusters.upper
        self.time_constants = thrusters.time_constants
        self.n = len(thrusters)
        f = np.zeros(self.n) if thrusts0 is None else plant.robot.check_velocity(thrusts0, self.n, "thrusts0").copy()
        if np.any(f < self.lower) or np.any(f > self.upper):
            raise ConfigurationError(f"thrusts0 {f.tolist()} must lie within [{self.lower.tolist()}, "
                                     f"{self.upper.tolist()}] N")
        self.thrusts0 = f
        self.fins = Fins() if fins is None else fins
        self.m = len(self.fins)

    @classmethod
    def of(cls, plant: Plant, *, fins: bool = True) -> ActuatedPlant:
        """``plant`` with its model's thrusters (:func:`uvms.dynamics.thrusters.thrusters.thrusters_of`) and, with
        ``fins``, its fins (:func:`uvms.dynamics.thrusters.fins.fins_of`), at rest at t = 0.

        Raises:
            ModelCheckError: a thruster on an arm link. UVMSError: no thrusters (the message says where they go).
        """
        return cls(plant, thrusters_of(plant.robot), fins=fins_of(plant.robot) if fins else None)

    def fin_wrench(self, q: np.ndarray, v: np.ndarray, angles: np.ndarray) -> np.ndarray:
        """The fins' lift and drag (6,) [N, N m] at the base frame at the velocity v (nv,) and angles (m,) [rad]."""
        if not self.m:
            return np.zeros(6)
        return self.fins.wrench(base_twist(self.plant, v), water_in_base(self.plant, q), angles)

    def saturate(self, command: np.ndarray) -> np.ndarray:
        """The command (n,) clipped to [lower, upper] [N] (``np.clip``'s numbers in one compiled call:
        :func:`uvms.numerics._kernels.plant_stage.clipped`)."""
        return (_CLIPPED.function or _CLIPPED.load())(np.asarray(command, dtype=float), self.lower, self.upper)

    def system(self, controller: Controller, *, dt: float, control_dt: float = 0.0) -> ActuatedPlantSystem:
        """This plant under ``controller`` (``command(state, t) -> Command``), asked once per step of dt [s].

        Raises:
            StepCountError: control_dt other than 0 or dt (the controller runs once per step).
        """
        if control_dt not in (0.0, dt):
            raise StepCountError(f"an actuated plant's controller runs once per step: control_dt must be 0 or dt = "
                                 f"{dt:g} s, got {control_dt!r}")
        return ActuatedPlantSystem(self, controller)


#: The thrust saturation and a step's command checked and saturated in one call (numba loaded where used).
_CLIPPED = Kernel("plant_stage", "clipped")
_FINITE_CLIPPED = Kernel("plant_stage", "finite_clipped_into")


# ------------------------------------------------------------------ model terms used by controllers and records
def base_twist(plant: Plant, v: np.ndarray) -> np.ndarray:
    """The vehicle's body twist (6,) [m/s, rad/s] in its base frame (FLU) from the velocity v (nv,)."""
    joint_twist = pin.Motion(v[:6]) if plant.nb == 6 else pin.Motion(np.array([v[0], v[1], 0.0, 0.0, 0.0, v[2]]))
    return plant._base_placement.actInv(joint_twist).vector


def water_in_base(plant: Plant, q: np.ndarray) -> np.ndarray:
    """The plant's ocean current (3,) [m/s] in the vehicle's base frame at q."""
    if not np.any(plant._current):
        return np.zeros(3)
    rotation = (plant.robot.base_pose(q) * plant._base_placement).rotation
    return rotation.T @ plant._current


def vehicle_inverse_dynamics(plant: Plant, q: np.ndarray, v: np.ndarray, base_acceleration: np.ndarray,
                             arm_acceleration: np.ndarray, *, base_frame: bool = False, out: np.ndarray | None = None,
                             placement: tuple[np.ndarray, np.ndarray] | None = None,
                             second: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """The body wrench (6,) [N, N m] at the base frame that gives the vehicle ``base_acceleration``.

    The vehicle rows of the plant's own equations of motion (rigid-body + added-mass inertia, Coriolis,
    damping, restoring, current: those the Plant was built with), Mbar_bb a_b + Mbar_bm a_m + nbar_b,
    mapped from the vehicle joint to the base frame. This is Fossen's M nu' + C(nu) nu + D(nu) nu + g(eta)
    of the whole UVMS, the arm's reaction included when v and a_m hold the arm's motion.

    Args:
        plant: the model (its current, damping, gravity choices apply).
        q: (nq,); v: (nv,) [m/s, rad/s] (vehicle part in the vehicle joint's local axes, as in the plant).
        base_acceleration: (nb,) vehicle twist rate, same axes as v, or with ``base_frame`` the base frame's (6,)
            (body FLU at its origin: mapped to the joint's axes as ``base_placement.act(pin.Motion(...))``);
        arm_acceleration: (n_arm,); out: (6,) written and returned (None: a new array).
        placement: the plant's joint_M_base as arrays (R (3, 3), p (3,)) a caller keeps (None: read from the plant).
        second: (v2 (nv,), Mbar (nv, nv), nbar (nv,)) of a floating vehicle: Mbar at q and nbar at v2 written there
            too, in the same compiled call (crba and the Jacobians once).
    """
    nb = plant.nb
    wrench = np.empty(6) if out is None else out
    if nb == 6:  # Pinocchio's calls, then the plant's terms and these expressions' numbers in one compiled call
        if placement is None:
            placement = plant._base_placement.rotation, plant._base_placement.translation
        base, arm = np.asarray(base_acceleration, dtype=float), np.asarray(arm_acceleration, dtype=float)
        plant._compiled().vehicle_wrench_into(q, v, base, arm, placement, base_frame, wrench, second)
        return wrench
    mass, bias = plant._mass_and_bias(q, v)
    placement = plant._base_placement
    if base_frame:  # the joint's rate; a planar joint's (vx, vy, wz) of it
        base_acceleration = placement.act(pin.Motion(np.asarray(base_acceleration, dtype=float))).vector[[0, 1, 5]]
    generalized = mass[:nb, :nb] @ base_acceleration + mass[:nb, nb:] @ arm_acceleration + bias[:nb]
    if nb == 3:  # planar: the joint's (fx, fy, mz) rows
        generalized = np.array([generalized[0], generalized[1], 0.0, 0.0, 0.0, generalized[2]])
    wrench[:] = placement.actInv(pin.Force(generalized)).vector
    return wrench


def lag_command(rate: np.ndarray, wanted: np.ndarray, dt: float, time_constant: float | np.ndarray) -> np.ndarray:
    """The command u held over one step dt [s] that brings a first-order lag x' = (u - x) / tau from ``rate`` x to
    ``wanted`` at the step's end: u = x + (wanted - x) / (1 - exp(-dt / tau)) (the lag inverted over the step).

    The arm's servos (qdd = (u - qd) / tau, :meth:`~uvms.dynamics.plant.plant.Plant.dynamics`) reach the rates asked
    one step later, not tau later, moving monotonically between the two (a rate within the limits is never passed).

    Args:
        rate: x (n,) now; wanted: (n,) at the step's end; dt: the step [s] > 0; time_constant: tau (n,) or [s] > 0.
    """
    return rate + (wanted - rate) / lag_factor(dt, time_constant)


def lag_factor(dt: float, time_constant: float | np.ndarray) -> np.ndarray:
    """1 - exp(-dt / tau) (numpy's expm1; a number or (n,)): the part of the way to its command a first-order lag
    x' = (u - x) / tau goes over one step dt [s] (:func:`lag_command` divides by it)."""
    return -np.expm1(-dt / np.asarray(time_constant, dtype=float))


def damping_power(plant: Plant, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Power (N,) [W] of the links' damping wrenches on the links, sum_l f_D,l . nu_l (<= 0 in still water), at the
    stored states q (N, nq), v (N, nv): derived after the loop, not recorded per row.

    Per row only Pinocchio's forward kinematics and the links' joints' twists (and rotations in a current) are
    gathered; the links' twists and wrenches are then formed for all rows at once, each row's numbers those of
    :meth:`uvms.dynamics.plant.conserved.ConservedQuantities._link_states` (the same operations per row).
    """
    rows = len(q)
    if not plant.damping or not plant.links:
        return np.zeros(rows)
    model, data, stacked = plant.model, plant.data, plant._stacked
    joints = plant._joints  # each joint once; the links' rows of it: plant._link_joint
    moving = bool(np.any(plant._current != 0.0))
    velocities, rotations = [], []  # per row (K, 6) and (K, 3, 3): the joints' twists (local) and rotations
    for q_k, v_k in zip(q, v):
        pin.forwardKinematics(model, data, q_k, v_k)
        twists = data.v.tolist()  # one call for all joints (views of data: copied at once by np.array)
        velocities.append(np.array([twists[joint].vector for joint in joints]))
        if moving:
            placed = data.oMi.tolist()
            rotations.append(np.array([placed[joint].rotation for joint in joints]))
    slots = plant._link_joint
    twists = (stacked.motion_to_link @ np.array(velocities)[:, slots, :, None])[..., 0]  # (N, L, 6)
    relative = twists
    if moving:  # nu_r = nu - [R^T v_c; 0]
        relative = twists.copy()
        relative[..., :3] -= plant._current @ (np.array(rotations)[:, slots] @ stacked.rotations)
    return (stacked.damping_wrenches(relative) * twists).reshape(rows, -1).sum(axis=1)


# ------------------------------------------------------------------ the system of the one loop
@dataclass(slots=True)
class ActuatedSample:
    """The plant at the start of a step: the held commands and the dynamics they give (plain slots, never changed).

    Attributes:
        rate: (v (nv,), [v' (nv,), f' (n,), delta' (m,)]); command: the controller's Command, checked (arm,
            thrust and fins filled, info a dict);
        thrust_command: sat(f_cmd) (n,) [N]; dynamics: accelerations and motor torques;
        fin_command: sat(delta_cmd) (m,) [rad]; wrench: the actuators' wrench (6,) [N, N m] on the vehicle at the
        step's start, base frame (B f plus the fins'; None: not kept).
    """

    rate: tuple[np.ndarray, np.ndarray]
    command: Command
    thrust_command: np.ndarray
    dynamics: PlantDynamics
    fin_command: np.ndarray = field(default_factory=lambda: np.zeros(0))
    wrench: np.ndarray | None = None


class ActuatedPlantSystem:
    """The plant with thrusters under a digital controller, as the state (q, [v, f]) of
    :func:`uvms.sim.loop.run_loop`.

    Args:
        actuated: the ActuatedPlant.
        controller: its ``command(state, t)`` asked once per step (see the module docstring); None: nothing
            commanded (zero arm rates and thrusts).
    """

    def __init__(self, actuated: ActuatedPlant, controller: Controller | None) -> None:
        self.plant, self.thrusters, self.controller = actuated.plant, actuated, controller
        self.robot, self.model = actuated.robot, actuated.model
        self.nv, self.m = actuated.model.nv, actuated.m
        self._n = self.nv + actuated.n  # where the fin angles start in the state
        self._passive = PlantSystem(actuated.plant, None, dt=1.0)  # its derived series: energies, momentum
        from ...numerics._kernels.plant_stage import actuation_rows  # numba: loaded where a plant is integrated

        self._rows_kernel = actuation_rows
        self._lag = (self.thrusters.matrix, self.thrusters.time_constants)  # B (6, n), tau (n,): the stage's thrusters
        self._no_fins = np.zeros(0)
        self._held = [np.zeros(self.plant.n_arm), np.zeros(actuated.n)]  # the step's [u, sat(f_cmd)], held
        self._stage: Callable | None = None  # the stage reading them, made at the first step (numba loads there)

    def initial_state(self, q0: np.ndarray, v0: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """(q0, [v0, thrusts0, fin angles at rest]) checked (v0 None: rest; thrusts0 the ActuatedPlant's).

        Raises:
            ConfigurationError: q0 or v0 of the wrong size or non-finite, a non-unit quaternion.
        """
        q, v = self._passive.initial_state(q0, v0)
        x = np.concatenate([v, self.thrusters.thrusts0, self.thrusters.fins.held])
        if self.controller is not None:
            self.controller.reset(self._state(q, x), 0.0)
        return q, x

    def _state(self, q: np.ndarray, x: np.ndarray) -> State:
        """What the controller measures: (q, v, thrusts, fin angles)."""
        return State(q, *self._split(x))

    def _command(self, t: float, q: np.ndarray, x: np.ndarray) -> tuple[Command, np.ndarray]:
        """The controller's Command at (t, q, x), its arm, thrust and fins filled (zero when not sent), checked, and
        its thrust command saturated (n,) [N] (``ActuatedPlant.saturate``'s numbers, in the check's compiled call).

        Raises:
            UVMSError: a field the plant cannot apply, or commands of the wrong size or non-finite.
        """
        if self.controller is None:
            command = Command()
        else:
            command = self.controller.command(self._state(q, x), t)
            if command.velocity is not None or command.arm_torque is not None:  # (the fields it does not take)
                refuse_fields(command, TAKEN, "an actuated plant (joint velocity servos, thrusters, fins)", t)
        arm = np.zeros(self.plant.n_arm) if command.arm is None else np.asarray(command.arm, dtype=float)
        thrust = np.zeros(self.thrusters.n) if command.thrust is None else np.asarray(command.thrust, dtype=float)
        rest = self.thrusters.fins.held if self.m else self._no_fins  # fins not commanded (none: one empty array)
        fins = rest if command.fins is None else np.asarray(command.fins, dtype=float)
        actuated, saturated = self.thrusters, np.empty(self.thrusters.n)
        if arm.shape != (self.plant.n_arm,) or thrust.shape != (actuated.n,) or fins.shape != (self.m,) \
                or not ((_FINITE_CLIPPED.function or _FINITE_CLIPPED.load())(arm, thrust, actuated.lower,
                                                                           actuated.upper, saturated)
                        and (not self.m or check_finite(fins, fins))):
            raise UVMSError(f"the controller must return {self.plant.n_arm} finite joint velocities, "
                            f"{self.thrusters.n} finite thrusts [N] and {self.m} fin angles [rad], got {arm!r}, "
                            f"{thrust!r} and {fins!r} at t = {t:.6g} s")
        if arm is command.arm and thrust is command.thrust and fins is command.fins and command.info is not None:
            return command, saturated  # as it came: its fields the checked arrays
        return Command(arm=arm, thrust=thrust, fins=fins, info={} if command.info is None else command.info), saturated

    def _rate(self, q: np.ndarray, x: np.ndarray, arm: np.ndarray, thrust_command: np.ndarray,
              fin_command: np.ndarray, torques: bool = True) -> tuple[PlantDynamics | None,
                                                                      tuple[np.ndarray, np.ndarray], np.ndarray]:
        """(the dynamics (None without ``torques``: an integrator's stage), the state's rate (v, [v', f', delta']),
        the actuators' wrench (6,)) at (q, x)."""
        thrusters, nv, n = self.thrusters, self.nv, self._n
        v = x[:nv]
        fin_wrench = thrusters.fin_wrench(q, v, x[n:]) if self.m else None  # (without fins none: not added)
        rates, wrench = np.empty(len(x)), np.empty(6)  # [v', f', delta'], each part written in place
        # B f (+ the fins'), the lag's f' = (sat(f_cmd) - f) / tau and the plant's terms in one compiled call
        dynamics = self.plant.actuated_rate_into(q, x, arm, thrust_command, self._lag, fin_wrench, wrench, rates,
                                                 torques)
        if self.m:
            rates[n:] = thrusters.fins.rate(x[n:], fin_command)
        return dynamics, (v, rates), wrench

    def _split(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(v (nv,), thrusts (n,), fin angles (m,)) of the state x."""
        n = self._n
        return x[:self.nv], x[self.nv:n], x[n:]

    def sample(self, t: float, q: np.ndarray, x: np.ndarray) -> ActuatedSample:
        """The controller's command at the step's start and the rate it gives."""
        command, saturated = self._command(t, q, x)
        fins = self.thrusters.fins.saturate(command.fins) if self.m else command.fins  # (none: clipped, the same)
        dynamics, rate, wrench = self._rate(q, x, command.arm, saturated, fins)
        return ActuatedSample(rate, command, saturated, dynamics, fins, wrench)

    def stage_rate(self, sample: ActuatedSample) -> Callable[[float, np.ndarray, np.ndarray], tuple]:
        """(t, q, x) -> (v, [v', f']) with the step's commands held (until the next call); without fins the plant's
        stage made once, pointed at them (:meth:`uvms.dynamics.plant.plant.Plant.actuated_stage`: the same numbers)."""
        arm, thrust_command, fin_command = sample.command.arm, sample.thrust_command, sample.fin_command
        if self.m:  # the fins' wrench and rate at each stage
            return lambda t, q, x: self._rate(q, x, arm, thrust_command, fin_command, False)[1]
        self._held[0], self._held[1] = arm, thrust_command
        if self._stage is None:
            self._stage = self.plant.actuated_stage(self._held, self._lag)
        return self._stage

    def record(self, t: float, q: np.ndarray, x: np.ndarray, sample: ActuatedSample) -> dict:
        """The plant series of a row (v, command, torques; energies, momentum and the damping power come from the
        stored states after the loop: :meth:`series_info`) and the thrusters' and controller's."""
        v, thrusts, angles = self._split(x)
        row = plant_row(v, sample.command.arm, sample.dynamics.joint_torque)  # (a passive plant's, no controller)
        if self.m:  # the fins' angles and what they give (their power: the drag's, <= 0 at rest angles)
            fin_wrench = self.thrusters.fin_wrench(q, v, angles)
            row.update(fin_angles=angles.copy(), fin_command=sample.fin_command, fin_wrench=fin_wrench,
                       fin_power=float(fin_wrench @ base_twist(self.plant, v)))
        row["thrusts"], row["thrust_command"] = thrusts.copy(), sample.thrust_command
        row.update(sample.command.info)
        return row

    def check(self, t: float, q: np.ndarray, x: np.ndarray, dt: float) -> None:
        """Raise UVMSError when the state reached at t [s] is not finite (the step dt was too large)."""
        check_finite_state(t, q, x, dt)

    def series_info(self) -> dict:
        """{"thrust_bounds": (lower (n,), upper (n,) [N]), "plant_series": the energies and momentum of the stored
        states (:meth:`uvms.dynamics.plant.system.PlantSystem.derived_series`), "actuation_series": the wrench and
        powers of the stored rows (:meth:`derived_series`), and "controller_series" when the controller derives
        series of its own from the stored rows (its ``derived_series(t (N,), q (N, nq))``: the actuated chain's
        errors)}."""
        info = {"thrust_bounds": (self.thrusters.lower, self.thrusters.upper),
                "plant_series": self._passive.derived_series, "actuation_series": self.derived_series}
        controller_series = getattr(self.controller, "derived_series", None)
        if controller_series is not None:
            info["controller_series"] = controller_series
        return info

    def derived_series(self, q: np.ndarray, v: np.ndarray, recorded: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """The actuation series derived after the loop from the stored rows q (N, nq), v (N, nv) and ``recorded``
        ("thrusts" (N, n), "joint_torque" (N, n_arm), with fins "fin_wrench" (N, 6)), each row's numbers those the
        record computed per row before: "body_wrench" (N, 6) [N, N m] B f + the fins', "thrust_power" (N,) [W]
        sum_i f_i (B_i . nu) (thruster i's power on the hull: f_i d_i . (v + w x p_i)), "thruster_power_abs" (N,)
        [W], "motor_power" (N,) [W] tau_m . qd_m (:func:`uvms.numerics._kernels.plant_stage.actuation_rows`, one
        compiled pass), "damping_power" (N,) [W] (:func:`damping_power`)."""
        placement = self.plant.base_placement
        fins = recorded["fin_wrench"] if self.m else np.zeros((0, 6))
        wrench, thrust_power, absolute, motor = self._rows_kernel(
            self.thrusters.matrix, np.ascontiguousarray(recorded["thrusts"], dtype=float), np.ascontiguousarray(v),
            np.ascontiguousarray(recorded["joint_torque"], dtype=float), np.ascontiguousarray(fins, dtype=float),
            self.plant.nb, placement.rotation.copy(), placement.translation.copy())
        return {"body_wrench": wrench, "thrust_power": thrust_power, "thruster_power_abs": absolute,
                "motor_power": motor, "damping_power": damping_power(self.plant, q, v)}
