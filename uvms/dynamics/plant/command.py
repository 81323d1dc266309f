"""What a controller sees of a plant (:class:`State`) and what it sends it (:class:`Command`), one control step.

Every controller (:class:`uvms.control.base.Controller`) answers ``command(state, t) -> Command`` whatever the plant;
each plant's system (:mod:`uvms.sim.kinematic`, :mod:`uvms.dynamics.plant.system`, :mod:`uvms.dynamics.plant.actuated`)
builds the State from its own and takes the Command's fields it can apply, refusing the others by name. They live
here, below the controllers, because the plants read them.

=========================  ===================================  =========================================
plant                      State                                Command fields it applies
=========================  ===================================  =========================================
kinematic (a ``Robot``)    q                                    velocity (nv,)
passive (``Plant``)        q, v                                 arm (n_arm,) (none: zero)
actuated (``ActuatedPlant``)  q, v, thrusts, fins               arm, thrust (n,), fins (m,)
=========================  ===================================  =========================================

``arm_torque`` is the form of a controller that commands the joints' torques (a model-predictive controller):
the plants that ship drive their joints through velocity servos and refuse it with a clear message.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np

from ...errors import UVMSError


@dataclass(frozen=True, slots=True)
class State:
    """The measured state of a plant at one control step.

    Attributes:
        q: configuration (nq,).
        v: velocity (nv,) [m/s, rad/s] (vehicle part in its joint's local axes); None in a kinematic run.
        thrusts: the thrusters' present thrusts (n,) [N]; None without thrusters.
        fins: the fins' present angles (m,) [rad]; None without thrusters.
    """

    q: np.ndarray
    v: np.ndarray | None = None
    thrusts: np.ndarray | None = None
    fins: np.ndarray | None = None


@dataclass(frozen=True, slots=True)
class Command:
    """What a controller sends for one control step; the fields a plant does not take stay None.

    Attributes:
        velocity: v (nv,) [m/s, rad/s] a kinematic plant integrates.
        arm: the joints' velocity command u (n_arm,) [rad/s or m/s] to their servos.
        arm_torque: the joints' torques (n_arm,) [N m or N] (a torque-controlled arm).
        thrust: the thrust command f_cmd (n,) [N] (clipped to the thrusters' bounds by the plant).
        fins: the fin angle command delta_cmd (m,) [rad] (clipped to the fins' limits).
        info: what the row records of the controller: a kinematic controller's SolverResult (sigma_min, damping,
            limits_active), an actuated chain's series (name -> value); None: nothing.
    """

    velocity: np.ndarray | None = None
    arm: np.ndarray | None = None
    arm_torque: np.ndarray | None = None
    thrust: np.ndarray | None = None
    fins: np.ndarray | None = None
    info: Any = None


#: Every field of a Command a controller may fill (its info aside).
COMMAND_FIELDS = ("velocity", "arm", "arm_torque", "thrust", "fins")


def refuse_fields(command: Command, taken: tuple[str, ...], plant: str, t: float) -> None:
    """Raise when ``command`` fills a field the plant cannot apply (a silent drop would be a false success).

    Raises:
        UVMSError: the first such field, with what the plant takes.
    """
    for name in COMMAND_FIELDS:
        if name not in taken and getattr(command, name) is not None:
            raise UVMSError(f"the controller sent Command.{name} at t = {t:.6g} s, which {plant} cannot apply; it "
                            f"takes {', '.join(f'Command.{field}' for field in taken)}")


@runtime_checkable
class Controller(Protocol):
    """What runs each control step of a run, whatever the plant (:mod:`uvms.control.base`: its implementations);
    here beside State and Command, which the plants read too."""

    def reset(self, state: State, t: float = 0.0) -> None:
        """Start a run from ``state`` at t [s]: integrators, saturation feedback and warm starts back to their
        initial values, so that a controller run twice gives the same run."""

    def command(self, state: State, t: float) -> Command:
        """The command applied from (state, t [s]) until the next control step."""
