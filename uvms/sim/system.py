"""The System protocol: what the one loop (:func:`uvms.sim.loop.run_loop`) integrates.

A system is a state (q, x) — q (nq,) on the configuration manifold of ``model``, x (m,) a vector (empty for a
kinematic run, the velocity v (nv,) for a plant, [v, thrusts] with thrusters) — and what drives it. Per step
the loop calls ``sample`` once at the step's start (what is applied from there: a controller's velocity, a
joint or thrust command, with the state's rate ``sample.rate``), integrates with ``stage_rate(sample)`` at the
integrator's stages, records the row with ``record`` and refuses a bad state with ``check``.

Three kinds ship: :class:`uvms.sim.kinematic.KinematicSystem` (q' = v from a kinematic controller),
:class:`uvms.dynamics.plant.plant.PlantSystem` (a free-floating plant under a joint-velocity command) and
:class:`uvms.dynamics.plant.actuated.ActuatedPlantSystem` (a plant with thrusters under a digital vehicle controller).
What :func:`uvms.sim.loop.simulate` is given builds its system: a :class:`Simulable` (``Plant``,
``ActuatedPlant``) by its ``system`` method, a ``Robot`` as a kinematic system.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol

import numpy as np
import pinocchio as pin

from ..control.base import Controller
from ..robot.robot import Robot

#: The rate of a state at an integrator stage: (t [s], q (nq,), x (m,)) -> (w (nv,) tangent at q, xdot (m,)).
StageRate = Callable[[float, np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]
#: A recorder maps (t [s], q (nq,), x (m,), sample) to more series of a row, name -> value.
Recorder = Callable[[float, np.ndarray, np.ndarray, Any], dict]


class Sample(Protocol):
    """What a system applies from the start of a step."""

    rate: tuple[np.ndarray, np.ndarray]  # (w (nv,), xdot (m,)) at the step's start: the integrator's first stage


class System(Protocol):
    """A state (q, x) and what drives it, as the loop integrates and records it (module docstring)."""

    robot: Robot  # the model the run records on
    model: pin.Model  # the manifold q lives on (the robot's, or the plant's copy)

    def initial_state(self, q0: np.ndarray, v0: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """(q (nq,), x (m,)) at t = 0 from q0 and the initial velocity v0 (nv,) (None: rest), both checked; the
        controller reset there (``controller.reset(state, 0.0)``).

        Raises:
            ConfigurationError: q0 or v0 of the wrong size, non-finite, or v0 given to a system without velocity.
        """

    def sample(self, t: float, q: np.ndarray, x: np.ndarray) -> Sample:
        """What is applied from (t [s], q, x), with the state's rate there."""

    def stage_rate(self, sample: Sample) -> StageRate:
        """The rate at the integrator's stages of the step that ``sample`` starts."""

    def record(self, t: float, q: np.ndarray, x: np.ndarray, sample: Sample) -> dict[str, Any]:
        """The system's own series of the row at t [s], name -> value."""

    def check(self, t: float, q: np.ndarray, x: np.ndarray, dt: float) -> None:
        """Refuse the state reached at t [s] after a step of dt [s] (non-finite...).

        Raises:
            UVMSError: what is wrong with the state, and what to change.
        """

    def series_info(self) -> dict[str, Any]:
        """What the result's series groups need beside the rows: ``"tracking"`` (frame, position rows) of a
        tracking controller, ``"thrust_bounds"`` (lower (n,), upper (n,) [N]) of thrusters, ``"plant_series"``
        ((q (N, nq), v (N, nv)) -> the plant's series derived from the stored states, computed when first read) of a
        plant, ``"actuation_series"`` ((q, v, the rows recorded by name) -> the actuation series not recorded per
        row: the body wrench, the powers) of thrusters, ``"controller_series"`` ((t (N,), q (N, nq)) -> series of the
        controller derived from the stored rows: the actuated chain's errors); {} when none."""


class Simulable(Protocol):
    """A plant that builds the system :func:`uvms.sim.loop.simulate` integrates (``Plant``, ``ActuatedPlant``)."""

    def system(self, controller: Controller | None, *, dt: float, control_dt: float = 0.0) -> System:
        """The system of this plant driven by ``controller`` (``command(state, t)``; None: nothing commanded),
        integrated with steps of dt [s]; control_dt [s]: the controller's period (0: asked at every integrator
        stage).

        Raises:
            StepCountError: a control_dt the plant cannot run its controller at.
        """
