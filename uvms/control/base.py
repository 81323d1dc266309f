"""The one controller interface: what runs each control step, whatever the plant.

A :class:`Controller` is reset once at the start of a run and asked ``command(state, t)`` at every control step
(every integrator stage of a kinematic run, every step of a digital controller); :func:`uvms.sim.loop.simulate`
drives every plant's controller this way and no other. The kinematic tracking
(:class:`uvms.control.tracking.TrackingController`), the phase sequences
(:class:`uvms.control.sequence.SequenceController`), the GJM controller of a passive vehicle
(:class:`uvms.control.gjm.GJMController`) and the actuated chain (:class:`uvms.control.coordination.CoordinatedControl`:
kinematic reference, vehicle loops, allocation, coordination) implement it, and so do :class:`OpenLoop` and the
whole-body MPC (:class:`uvms.control.mpc.controller.MPCController`, which fills ``Command.thrust`` and the arm's
servo commands; a torque-controlled arm would fill ``Command.arm_torque``).

Each controller that solves receives its solver in one form, a :class:`uvms.solvers.base.SolverFactory` (built
per level set), and asks it what it can do by the class's attributes
(:attr:`~uvms.solvers.base.Solver.holds_priorities`, ...).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..dynamics.plant.command import Command, Controller, State

__all__ = ["Command", "Controller", "OpenLoop", "State"]


#: A command signal: a constant array, or t [s] -> array.
Signal = np.ndarray | Callable[[float], np.ndarray] | None


class OpenLoop:
    """Commands that depend on time only (open loop): each a constant or a function of t [s], None: not sent.

    Args:
        velocity: v (nv,) of a kinematic run; arm: joint velocity commands (n_arm,); arm_torque: joint torques;
            thrust: thrust commands (n,) [N]; fins: fin angles (m,) [rad]; info: recorded with each row.
    """

    def __init__(self, *, velocity: Signal = None, arm: Signal = None, arm_torque: Signal = None,
                 thrust: Signal = None, fins: Signal = None, info: object = None) -> None:
        self.signals = {name: signal for name, signal in (("velocity", velocity), ("arm", arm),
                                                          ("arm_torque", arm_torque), ("thrust", thrust),
                                                          ("fins", fins)) if signal is not None}
        self.info = info

    def reset(self, state: State, t: float = 0.0) -> None:
        """Nothing to reset: the commands depend on time only."""

    def command(self, state: State, t: float) -> Command:
        """Every signal at t."""
        values = {name: np.asarray(signal(t) if callable(signal) else signal, dtype=float)
                  for name, signal in self.signals.items()}
        return Command(**values, info=self.info)
