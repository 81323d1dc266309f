"""The optional series groups of a :class:`uvms.sim.result.SimulationResult`: plant, tracking, actuation.

Each is a frozen dataclass of (N, ...) arrays, row k at t[k], present only when the run recorded it: the plant
series of a free-floating plant run, the tracking series of a tracking controller (the GJM controller of
amundsen2018), the actuation series of a plant with thrusters.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

#: The series of :class:`PlantSeries`, by name.
PLANT_FIELDS = ("command", "joint_torque", "kinetic_energy", "potential_energy", "momentum")
#: Those of them a plant's loop records per row (the others are derived from the stored states when read).
PLANT_RECORDED = ("command", "joint_torque")
#: The series of :class:`TrackingSeries` recorded per row (ee_position and desired_position are the result's).
TRACKING_FIELDS = ("rates", "ee_velocity", "desired_velocity")
#: The series an actuated plant gives (:class:`ActuationSeries`: per row, damping_power derived from the stored states
#: after the loop); its controller's go to ``controller``.
ACTUATION_FIELDS = ("thrusts", "thrust_command", "body_wrench", "thrust_power", "thruster_power_abs", "motor_power",
                    "damping_power")
#: The series of a plant with fins (:class:`uvms.dynamics.plant.actuated.ActuatedPlant`): their angles and command
# [rad],
#: their wrench (6,) [N, N m] and its power [W].
FIN_SERIES = ("fin_angles", "fin_command", "fin_wrench", "fin_power")
#: The actuation series that ``actuation.npz`` holds, in its order (the others stay in memory; the fins' with fins).
ACTUATION_SERIES = ("thrusts", "thrust_command", "body_wrench", "wrench_command", "achieved_wrench", "thrust_power",
                    "thruster_power_abs", "damping_power", "vehicle_position_error", "vehicle_attitude_error",
                    "ee_point_error", *FIN_SERIES)


@dataclass(frozen=True, init=False)
class PlantSeries:
    """The series of a free-floating plant run (:class:`uvms.dynamics.plant.plant.Plant`).

    The energies and the momentum are functions of the stored states: a run computes them from its rows when
    they are first read (``derive``), not inside its loop (an actuated run that never reads them never pays them).

    Attributes:
        command: (N, n_arm) joint-velocity commands u [rad/s or m/s].
        joint_torque: (N, n_arm) motor torques [N m or N].
        kinetic_energy, potential_energy: (N,) [J] (kinetic includes the added mass).
        momentum: (N, 6) [N s, N m s] world frame about the world origin, rigid + added mass.

    Args:
        command, joint_torque: as above; kinetic_energy, potential_energy, momentum: as above, or None with
            ``derive``: () -> {"kinetic_energy": ..., "potential_energy": ..., "momentum": ...}, called once when one
            of them is first read.
    """

    command: np.ndarray
    joint_torque: np.ndarray

    def __init__(self, command: np.ndarray, joint_torque: np.ndarray, kinetic_energy: np.ndarray | None = None,
                 potential_energy: np.ndarray | None = None, momentum: np.ndarray | None = None, *,
                 derive: Callable[[], dict[str, np.ndarray]] | None = None) -> None:
        given = {"kinetic_energy": kinetic_energy, "potential_energy": potential_energy, "momentum": momentum}
        if derive is None and any(value is None for value in given.values()):
            raise ValueError("PlantSeries needs kinetic_energy, potential_energy and momentum, or derive")
        object.__setattr__(self, "command", command)
        object.__setattr__(self, "joint_torque", joint_torque)
        object.__setattr__(self, "_derive", derive)
        for name, value in given.items():
            if value is not None:  # an instance value shadows the lazy property of that name
                object.__setattr__(self, name, value)

    def _derived(self, name: str) -> np.ndarray:
        derived = self.__dict__.get("_derived_series")
        if derived is None:
            derived = self._derive()  # type: ignore[attr-defined]
            object.__setattr__(self, "_derived_series", derived)
        return derived[name]

    @functools.cached_property
    def kinetic_energy(self) -> np.ndarray:  # noqa: D102 - the class docstring's
        return self._derived("kinetic_energy")

    @functools.cached_property
    def potential_energy(self) -> np.ndarray:  # noqa: D102
        return self._derived("potential_energy")

    @functools.cached_property
    def momentum(self) -> np.ndarray:  # noqa: D102
        return self._derived("momentum")

    @property
    def energy(self) -> np.ndarray:
        """Mechanical energy (N,) [J]: kinetic + potential."""
        return self.kinetic_energy + self.potential_energy

    def momentum_drift(self) -> np.ndarray:
        """max_t ``|h(t) - h(0)|`` of the linear and the angular momentum (2,) [N s, N m s]."""
        change = self.momentum - self.momentum[0]
        return np.array([np.max(np.linalg.norm(change[:, :3], axis=1)), np.max(np.linalg.norm(change[:, 3:], axis=1))])


@dataclass(frozen=True)
class TrackingSeries:
    """The series of a tracking controller driving a plant (the GJM controller's ``tracking``).

    Attributes:
        ee_position, desired_position: (N, 3) [m] world, the controlled frame and its reference.
        ee_velocity, desired_velocity: (N, 3) [m/s] world, linear velocity of the frame origin and its reference.
        rates: (N, n_arm) joint rates w [rad/s] of the controller before the servo feedforward.
        frame: the controlled frame; position_rows: the controller's position axes (0 x, 1 y, 2 z).
    """

    ee_position: np.ndarray
    desired_position: np.ndarray
    ee_velocity: np.ndarray
    desired_velocity: np.ndarray
    rates: np.ndarray
    frame: str
    position_rows: tuple[int, ...]

    @property
    def position_error(self) -> np.ndarray:
        """(N,) [m] norm of p_d - p over the controller's position axes (``plant.npz``'s position_error)."""
        return np.linalg.norm((self.desired_position - self.ee_position)[:, list(self.position_rows)], axis=1)

    @property
    def velocity_error(self) -> np.ndarray:
        """(N,) [m/s] norm of v_d - v over the controller's position axes."""
        return np.linalg.norm((self.desired_velocity - self.ee_velocity)[:, list(self.position_rows)], axis=1)


@dataclass(frozen=True)
class ActuationSeries:
    """The series of a plant with thrusters (:class:`uvms.dynamics.plant.actuated.ActuatedPlant`).

    Attributes:
        thrusts: (N, n) [N] each thruster's thrust; thrust_command: (N, n) [N] the saturated command.
        body_wrench: (N, 6) [N, N m] B f, FLU at the base frame origin.
        thrust_power: (N,) [W] B f . nu; thruster_power_abs: (N,) [W] sum_i ``|f_i (B_i . nu)|``.
        motor_power: (N,) [W] tau_m . qd_m; damping_power: (N,) [W] of the links' damping (<= 0 in still water).
        lower, upper: (n,) [N] the thrust bounds.
        controller: the controller's own series by name (e.g. wrench_command (N, 6), vehicle_position_error (N,)),
            read-only.
    """

    thrusts: np.ndarray
    thrust_command: np.ndarray
    body_wrench: np.ndarray
    thrust_power: np.ndarray
    thruster_power_abs: np.ndarray
    motor_power: np.ndarray
    damping_power: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    controller: Mapping[str, np.ndarray] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "controller", MappingProxyType(dict(self.controller)))

    def series(self, name: str) -> np.ndarray | None:
        """The series ``name``, the actuated plant's or its controller's (None: not recorded)."""
        if name in ACTUATION_FIELDS:
            return getattr(self, name)
        return self.controller.get(name)

    def arrays(self) -> dict[str, np.ndarray]:
        """The :data:`ACTUATION_SERIES` recorded, in ``actuation.npz``'s order."""
        return {name: self.series(name) for name in ACTUATION_SERIES if self.series(name) is not None}

    def metrics(self, t: np.ndarray) -> dict:
        """Numbers of an actuated run for ``metrics.json`` [SI units], t (N,) [s] the run's times.

        max_thrust_ratio: max over time and thrusters of ``|f_i|`` / (its limit in that direction), <= 1;
        saturated_time_fraction: fraction of rows with a thrust command at a bound;
        thrust_work: integral of the thrust power B f . nu [J] (signed: negative when the current pushes the
        vehicle back against its thrust); thruster_energy: integral of sum_i ``|f_i (B_i . nu)|`` [J], the mechanical
        power each thruster gives the hull, counted positive either way (not the electrical energy: no propeller
        efficiency model); both by the trapezoid rule. With a controller that records ``vehicle_position_error``
        (:class:`uvms.control.station.ActuatedKinematics`): vehicle_position_error (its max over the run) and
        final_vehicle_position_error [m].
        """
        thrusts, commands, lower, upper = self.thrusts, self.thrust_command, self.lower, self.upper
        limits = np.where(thrusts >= 0, upper, np.where(lower < 0, -lower, np.inf))
        at_bound = np.isclose(commands, upper) | np.isclose(commands, lower) & (lower < 0)
        metrics = {"max_thrust_ratio": float(np.max(np.abs(thrusts) / limits)),
                   "saturated_time_fraction": float(np.mean(np.any(at_bound, axis=1))),
                   "thrust_work": trapezoid(self.thrust_power, t),
                   "thruster_energy": trapezoid(self.thruster_power_abs, t)}
        error = self.controller.get("vehicle_position_error")
        if error is not None:
            metrics.update(vehicle_position_error=float(np.max(error)), final_vehicle_position_error=float(error[-1]))
        return metrics


def trapezoid(values: np.ndarray, t: np.ndarray) -> float:
    """The integral of ``values`` (N,) over t (N,) [s] by the trapezoid rule."""
    return float(np.sum(0.5 * (values[1:] + values[:-1]) * np.diff(t)))
