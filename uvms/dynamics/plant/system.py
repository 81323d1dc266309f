"""The free-floating plant under a joint-velocity command, as a system of the one loop (:mod:`uvms.sim.system`).

(q, v)' = (v, plant acceleration at (q, v) under u = ``controller.command(State(q, v), t).arm``), the controller
continuous (asked at every integrator stage) or digital (asked every control_dt, its command held).
:meth:`uvms.dynamics.plant.plant.Plant.system` builds it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from ...errors import StepCountError, UVMSError
from ...numerics._kernels import Kernel
from .command import Controller, State, refuse_fields

#: What a passive plant applies of a Command.
TAKEN = ("arm",)
#: The rate at an integrator stage: (t [s], q (nq,), v (nv,)) -> (v (nv,), v' (nv,)).
StageRate = Callable[[float, np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]


@dataclass(slots=True)
class PlantDynamics:
    """What the plant computes at one (q, v, u): accelerations and the motor torques that produce them (built at
    every evaluation: plain attribute writes; read it, it is never changed after it is built).

    Attributes:
        acceleration: v' (nv,) [m/s^2, rad/s^2] (vehicle body twist rate, local; joint accelerations).
        joint_torque: tau_m (n_arm,) [N m or N] the motors exert.
        mass_matrix: Mbar (nv, nv), rigid + added mass.
    """

    acceleration: np.ndarray
    joint_torque: np.ndarray
    mass_matrix: np.ndarray


class Plant(Protocol):
    """What a plant system asks of its plant (:class:`uvms.dynamics.plant.plant.Plant` is one; named here so that
    this module needs nothing of that one, which builds its systems from here)."""

    robot: Any
    model: Any
    n_arm: int

    def dynamics(self, q: np.ndarray, v: np.ndarray, command: np.ndarray,
                 body_wrench: np.ndarray | None = None) -> PlantDynamics: ...

    def stage_acceleration(self, q: np.ndarray, v: np.ndarray, command: np.ndarray) -> np.ndarray: ...

    def energy(self, q: np.ndarray, v: np.ndarray) -> tuple[float, float]: ...

    def momentum(self, q: np.ndarray, v: np.ndarray) -> np.ndarray: ...


@dataclass(slots=True)
class PlantSample:
    """The plant at the start of a step: the command applied from it and the dynamics it gives (built at every step:
    plain attribute writes, never changed after).

    Attributes:
        rate: (v (nv,), v' (nv,)): the state's derivative at (q, v), the integrator's first stage.
        command: u (n_arm,) [rad/s or m/s]; dynamics: accelerations and motor torques.
    """

    rate: tuple[np.ndarray, np.ndarray]
    command: np.ndarray
    dynamics: PlantDynamics


class PlantSystem:
    """The plant under a joint-velocity command, as the state (q, v) of :func:`uvms.sim.loop.run_loop`.

    (q, v)' = (v, plant acceleration at (q, v) under u = ``controller.command(State(q, v), t).arm``). A controller
    with a ``tracking(t, q, v) -> dict`` method (a tracking controller, e.g. the GJM controller, with its ``frame``
    and task ``rows``) has its series recorded with the plant's.

    Args:
        plant: the Plant.
        controller: a :class:`uvms.control.base.Controller` sending ``Command(arm=u (n_arm,))``, or None (zero).
        dt: the integration step [s]; control_dt: 0 (default): the controller is asked at every integrator
            stage; > 0, a multiple of dt: a digital controller, asked every control_dt [s], held in between.

    Raises:
        StepCountError: control_dt not 0 nor a positive multiple of dt.
    """

    def __init__(self, plant: Plant, controller: Controller | None, *, dt: float,
                 control_dt: float = 0.0) -> None:
        self.plant, self.robot, self.model = plant, plant.robot, plant.model
        self.controller = controller
        self._zero = np.zeros(plant.n_arm)
        self.dt, self.every = float(dt), control_steps(control_dt, dt)
        self.held: np.ndarray | None = None  # the digital controller's output, held between its samples

    def initial_state(self, q0: np.ndarray, v0: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """(q0, v0) checked (v0 None: rest); the controller reset there.

        Raises:
            ConfigurationError: q0 or v0 of the wrong size or non-finite, a non-unit quaternion.
        """
        robot = self.robot
        q = robot.check_configuration(q0).copy()
        v = np.zeros(self.model.nv) if v0 is None else robot.check_velocity(v0).copy()
        if self.controller is not None:
            self.controller.reset(State(q, v), 0.0)
        return q, v

    def command_at(self, t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """u (n_arm,) at (t, q, v), checked (no controller: zero).

        Raises:
            UVMSError: a field the plant cannot apply (torques, thrusts), or an arm command that is not n_arm
                finite numbers.
        """
        if self.controller is None:
            return self._zero
        command = self.controller.command(State(q, v), t)
        refuse_fields(command, TAKEN, "a plant without thrusters (joint velocity servos)", t)
        try:
            u = np.asarray(self._zero if command.arm is None else command.arm, dtype=float)
        except (TypeError, ValueError) as exc:
            raise UVMSError(f"the command failed at t = {t:.6g} s: {exc}") from None
        if u.shape != (self.plant.n_arm,) or not np.all(np.isfinite(u)):
            raise UVMSError(
                f"the command must return {self.plant.n_arm} finite joint velocities, got {u!r} at t = {t:.6g} s")
        return u

    def sample(self, t: float, q: np.ndarray, v: np.ndarray) -> PlantSample:
        """The command and the dynamics at the start of a step (a digital controller: sampled at its steps,
        else the held command)."""
        if self.every and (int(round(t / self.dt)) % self.every == 0 or self.held is None):
            self.held = self.command_at(t, q, v)
        u = self.held if self.every else self.command_at(t, q, v)
        dynamics = self.plant.dynamics(q, v, u)
        return PlantSample((v, dynamics.acceleration), u, dynamics)

    def stage_rate(self, sample: PlantSample) -> StageRate:
        """(t, q, v) -> (v, v') at the integrator's stages (the command held from ``sample`` when digital)."""
        plant = self.plant  # v' alone: a stage needs no motor torques
        if self.every:
            held = sample.command
            return lambda t, q, v: (v, plant.stage_acceleration(q, v, held))
        return lambda t, q, v: (v, plant.stage_acceleration(q, v, self.command_at(t, q, v)))

    def record(self, t: float, q: np.ndarray, v: np.ndarray, sample: PlantSample) -> dict:
        """The plant series of a row (v, the command, torques; the energies and momentum come from the stored
        states after the loop: :meth:`derived_series`) and a tracking controller's (with limits_active = 0: it
        holds no joint at a limit)."""
        row = plant_row(v, sample.command, sample.dynamics.joint_torque)
        tracking = getattr(self.controller, "tracking", None)
        if tracking is not None:
            row.update(tracking(t, q, v), limits_active=0)
        return row

    def derived_series(self, q: np.ndarray, v: np.ndarray) -> dict[str, np.ndarray]:
        """The energies (N,) [J] and momentum (N, 6) [N s, N m s] of the stored states q (N, nq), v (N, nv)."""
        plant = self.plant
        energies = np.array([plant.energy(q_k, v_k) for q_k, v_k in zip(q, v)]).reshape(len(q), 2)
        return {"kinetic_energy": energies[:, 0], "potential_energy": energies[:, 1],
                "momentum": np.array([plant.momentum(q_k, v_k) for q_k, v_k in zip(q, v)]).reshape(len(q), 6)}

    def check(self, t: float, q: np.ndarray, v: np.ndarray, dt: float) -> None:
        """Raise UVMSError when the state reached at t [s] is not finite (the step dt was too large)."""
        check_finite_state(t, q, v, dt)

    def series_info(self) -> dict:
        """{"plant_series": :meth:`derived_series`} and {"tracking": (frame, task rows)} of a tracking controller."""
        info: dict[str, Any] = {"plant_series": self.derived_series}
        if getattr(self.controller, "tracking", None) is not None:
            info["tracking"] = (self.controller.frame, tuple(self.controller.rows))
        return info


def plant_row(v: np.ndarray, command: np.ndarray, joint_torque: np.ndarray) -> dict[str, np.ndarray]:
    """The plant's own series of a row: v (nv,) (copied), the joint command u (n_arm,), the motor torques (n_arm,)."""
    return {"v": v.copy(), "command": command, "joint_torque": joint_torque}


def control_steps(control_dt: float, dt: float) -> int:
    """The steps of dt [s] per period of a digital controller of period control_dt [s] (0: continuous).

    Raises:
        StepCountError: control_dt not 0 nor a positive multiple of dt.
    """
    control_dt = float(control_dt)
    if control_dt == 0.0:
        return 0
    ratio = control_dt / dt
    if not (np.isfinite(ratio) and ratio >= 1 - 1e-9 and abs(ratio - round(ratio)) < 1e-6):
        raise StepCountError(f"control_dt must be 0 (continuous) or a positive multiple of dt = {dt:g} s, "
                             f"got {control_dt!r}")
    return int(round(ratio))


def check_finite_state(t: float, q: np.ndarray, x: np.ndarray, dt: float) -> None:
    """Raise UVMSError when the state (q, x) reached at t [s] is not finite (the step dt [s] was too large).

    One compiled call (:func:`uvms.numerics._kernels.plant_stage.all_finite`; numpy's four calls cost 1.7 us a step).
    """
    if not check_finite(q, x):
        raise UVMSError(f"the state became non-finite at t = {t:.6g} s; reduce dt (now {dt:g} s)")


def check_finite(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether every entry of the float arrays a and b is finite, in one compiled call
    (:func:`uvms.numerics._kernels.plant_stage.all_finite`, loaded at the first call: numba, which a plant's first
    evaluation loads anyway)."""
    return (_ALL_FINITE.function or _ALL_FINITE.load())(a, b)


_ALL_FINITE = Kernel("plant_stage", "all_finite")
