"""A log's per-thruster topics turned into the body wrench on the vehicle, through the model's thrusters.

A bag without a body-wrench topic can still be identified from when it holds one ``std_msgs/msg/Float64`` topic per
thruster, as ``uvms run --bag`` writes them (``/thrusters/<name>/thrust``, the thrust [N]) and uuv_simulator's
thruster topics do. The model's thrusters (:func:`uvms.dynamics.thrusters.thrusters.thrusters_of`: their frames, limits
and time constants) give the wrench tau = B f, B (6, n) the allocation matrix
(:func:`uvms.dynamics.thrusters.thrusters.allocation_matrix`) at the vehicle's root link, body FLU, as the
``/body_wrench`` topic holds it.

When the topics hold the thrust *commands*, the thrust is what the thrusters' model makes of them: the command
clipped to the limits and followed through the first-order lag f' = (sat(f_cmd) - f) / T, solved exactly for a
command held between its samples, f_(k+1) = c_k + (f_k - c_k) exp(-(t_(k+1) - t_k) / T). The thrust before the first
sample is unknown: it starts at the first command, and the first :data:`SETTLING` time constants of the log are
dropped (the start's error decays to exp(-10) = 5e-5 of itself).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...dynamics.thrusters.thrusters import allocation_matrix, thrusters_of
from ...errors import IdentificationError, UVMSError
from ...robot.robot import Robot
from .writer import thruster_tokens

#: The default topic of each thruster: ``{name}`` is the thruster's name as a topic token (as ``uvms run --bag``).
THRUST_TOPIC = "/thrusters/{name}/thrust"
#: Time constants of the lag dropped at the start of a log of thrust commands.
SETTLING = 10.0


@dataclass(frozen=True)
class ThrustInput:
    """How a log's thruster topics give the body wrench.

    Attributes:
        names: the thrusters (n); topics: their topics, in the same order; matrix: B (6, n) [-, m].
        time_constants, lower, upper: (n,) [s, N, N] of the lag and the limits, used when ``commands``.
        commands: the topics hold commands (the lag and limits applied), not thrusts.
    """

    names: tuple[str, ...]
    topics: tuple[str, ...]
    matrix: np.ndarray
    time_constants: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    commands: bool = False

    def thrust(self, index: int, t: np.ndarray, values: np.ndarray) -> np.ndarray:
        """The thrust (N,) [N] of thruster ``index`` at its samples t (N,) [s], from the topic's values (N,)."""
        if not self.commands:
            return values
        command = np.clip(values, self.lower[index], self.upper[index])
        decay = np.exp(-np.diff(t) / self.time_constants[index])
        thrust = np.empty_like(command)
        thrust[0] = command[0]
        for k, factor in enumerate(decay):
            thrust[k + 1] = command[k] + (thrust[k] - command[k]) * factor
        return thrust

    @property
    def settling(self) -> float:
        """The time [s] at the start of the log whose thrust is not known well enough (0 for measured thrusts)."""
        return SETTLING * float(np.max(self.time_constants)) if self.commands else 0.0


def thrust_input(robot: Robot, pattern: str = THRUST_TOPIC, *, commands: bool = False) -> ThrustInput:
    """The thrusters of ``robot`` and their topics, ``pattern`` with ``{name}`` replaced by each thruster's name.

    Raises:
        IdentificationError: a pattern without ``{name}``, a model without usable thrusters, or two thrusters whose
            names give the same topic (:func:`uvms.scenario.bags.writer.thruster_tokens`).
    """
    if "{name}" not in pattern or pattern.count("{") != 1 or pattern.count("}") != 1:
        raise IdentificationError(f"the thrust topic pattern must hold {{name}} once (e.g. {THRUST_TOPIC!r}), "
                                  f"got {pattern!r}")
    try:
        thrusters = thrusters_of(robot)
        matrix = allocation_matrix(robot, thrusters)
        tokens = thruster_tokens(thrusters.names)
    except UVMSError as exc:
        raise IdentificationError(f"a log of thrusts needs the model's thrusters: {' '.join(str(exc).split())}") \
            from None
    return ThrustInput(tuple(thrusters.names), tuple(pattern.replace("{name}", token) for token in tokens), matrix,
                       thrusters.time_constants, thrusters.lower, thrusters.upper, commands)
