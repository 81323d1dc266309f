"""ONE simulation: :func:`simulate` over the one loop :func:`run_loop`, for every system.

The loop integrates a system (:class:`uvms.sim.system.System`) with one of the integrators of
:mod:`uvms.numerics.integrate` (explicit Euler, RK4 Munthe-Kaas on the manifold) and records a row per step
through the system and any number of recorders, into the one immutable :class:`uvms.sim.result.SimulationResult`.
Every system drives its controller one way, the :class:`uvms.control.base.Controller` protocol: reset at the
start, ``command(state, t) -> Command`` at each control step. What is simulated decides the system and the
command's fields it applies:

* a ``Robot``: q' = ``Command.velocity`` (a tracking or sequence controller)
  (:class:`uvms.sim.kinematic.KinematicSystem`);
* a ``Plant`` (rigid or hydrodynamic): the passive free-floating plant under the joint-velocity command
  ``Command.arm`` — the GJM controller, an :class:`uvms.control.base.OpenLoop` or None (zero)
  (:class:`uvms.dynamics.plant.system.PlantSystem`);
* an ``ActuatedPlant`` (plant + thrusters): ``Command.arm``, ``thrust`` and ``fins`` from a digital controller such
  as the actuated chain (:class:`uvms.dynamics.plant.actuated.ActuatedPlantSystem`).

::

    simulate(robot, tracking, q0, 10.0, 0.01, task=task, desired=lambda t: trajectory(t).pose)
    simulate(plant, gjm_controller, q0, 8.0, 0.01)
    actuated = ActuatedPlant(plant, thrusters)
    simulate(actuated, station_keeping(actuated, q0, 0.01), q0, 6.0, 0.01)
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence

import numpy as np
import pinocchio as pin

from ..control.base import Controller
from ..errors import UVMSError
from ..io.progress import compile_notice, progress_bar
from ..numerics.integrate import STEPS, check_integrator, step_count
from ..robot.robot import Robot
from ..tasks.frame import FrameTask
from .kinematic import KinematicSystem, TaskSeries
from .result import SimulationResult
from .system import Recorder, Simulable, System

__all__ = ["run_loop", "simulate"]


def run_loop(system: System, q0: np.ndarray, x0: np.ndarray, *, steps: int, dt: float, integrator: str = "rk4",
             recorders: Sequence[Recorder] = (), progress: bool | None = None,
             desc: str = "simulate") -> tuple[dict[str, np.ndarray], float]:
    """Integrate ``system`` from (q0, x0) for ``steps`` steps of ``dt`` and record every row.

    Args:
        system: a System; q0: (nq,); x0: (m,), checked by the caller (``system.initial_state``).
        steps: the number of steps (:func:`uvms.numerics.integrate.step_count`); dt: [s].
        integrator: "euler" or "rk4".
        recorders: (t, q, x, sample) -> {name: value} after the system's own record, later ones win.
        progress: show a progress bar (None: only on a terminal); desc: its label.

    Returns:
        (the series by name, N = steps + 1 rows each, the wall time [s]).
    """
    step = STEPS[check_integrator(integrator)]
    q, x = q0, x0
    rows: list[dict] = []  # kept as they come, gathered by name after the loop (not a dict lookup per value)
    started = time.perf_counter()
    notice = compile_notice()  # the first step runs the solver's first call: its kernels compile after an install
    try:
        for k in progress_bar(range(steps + 1), progress, desc=desc, unit="step", leave=False):
            t = k * dt
            sample = system.sample(t, q, x)
            row = {"t": t, "q": q.copy(), **system.record(t, q, x, sample)}
            for recorder in recorders:
                row.update(recorder(t, q, x, sample))
            rows.append(row)
            if k == steps:
                break
            q, x = step(system.model, system.stage_rate(sample), t, q, x, dt, sample.rate)
            system.check(t + dt, q, x, dt)
            if k == 0:
                notice.cancel()
    finally:
        notice.cancel()
    return gathered(rows), time.perf_counter() - started


def gathered(rows: list[dict]) -> dict[str, np.ndarray]:
    """The series by name (in the order the names first came), each the array of its values over the rows that
    have it, in order."""
    first = rows[0].keys() if rows else {}
    if all(row.keys() == first for row in rows):  # the common case: every row has the same names
        return {name: np.array([row[name] for row in rows]) for name in first}
    names = dict.fromkeys(name for row in rows for name in row)
    return {name: np.array([row[name] for row in rows if name in row]) for name in names}


def simulate(
    system: Robot | Simulable,
    controller: Controller | None,
    q0: np.ndarray,
    duration: float,
    dt: float,
    *,
    v0: np.ndarray | None = None,
    integrator: str = "rk4",
    control_dt: float = 0.0,
    task: FrameTask | None = None,
    desired: Callable[[float], pin.SE3] | None = None,
    recorders: Sequence[Recorder] = (),
    progress: bool | None = None,
) -> SimulationResult:
    """Integrate ``system`` driven by ``controller`` from q0 for ``duration`` with a fixed step ``dt``.

    Args:
        system: a ``Robot`` (kinematic run), a ``Plant`` (passive free-floating) or an ``ActuatedPlant`` (module
            docstring); anything with ``system(controller, dt=, control_dt=) -> System``.
        controller: what drives it, a :class:`uvms.control.base.Controller` (reset at the start, then
            ``command(state, t)``), or None for a Plant: no joint command (zero).
        q0: initial configuration (nq,); v0: initial velocity (nv,) of a plant (None: rest).
        duration, dt: [s]; the number of steps is round(duration / dt), at least 1 and at most
            :data:`uvms.numerics.integrate.MAX_STEPS` (:func:`uvms.numerics.integrate.step_count`).
        integrator: "rk4" (Runge-Kutta-Munthe-Kaas, order 4 on the manifold) or "euler".
        control_dt: the controller's period [s], a multiple of dt, its command held in between (a digital
            controller); 0: a continuous one, evaluated at every integrator stage (an actuated plant's controller
            always runs once per step).
        task, desired: the task series (end effector against ``desired``: t -> pose, errors on the task's axes),
            derived from the stored rows after the loop by :class:`uvms.sim.kinematic.TaskSeries`; both or neither.
        recorders: more series per row, (t, q, x, sample) -> {name: value}; their names must be series of
            :class:`SimulationResult` (:data:`uvms.sim.result.SERIES`) other than the task's.
        progress: show a progress bar (None: only on a terminal).

    Returns:
        The immutable SimulationResult: the task series with ``task``, ``plant`` for a plant, ``tracking`` for a
        controller with ``tracking`` (the GJM controller), ``actuation`` with thrusters.

    Raises:
        StepCountError: no step or too many, a control_dt that is not a multiple of dt (checked before anything
            runs).
        UVMSError: an unknown integrator, task without desired, bad q0 or v0, a controller without
            ``command``, one returning non-finite or wrongly sized values or a field the plant cannot apply, a
            state that becomes non-finite (step too large).
    """
    integrator = check_integrator(integrator)
    steps = step_count(duration, dt)
    if (task is None) != (desired is None):
        raise UVMSError("task and desired go together: the task's frame and axes, and desired: t [s] -> the pose "
                        "(pin.SE3) the frame should have")
    if controller is not None and not isinstance(controller, Controller):
        raise UVMSError(f"the controller must have reset(state, t) and command(state, t) -> Command "
                        f"(uvms.control.Controller; uvms.control.OpenLoop for commands of time alone), got "
                        f"{type(controller).__name__}")
    if controller is None and isinstance(system, Robot):
        raise UVMSError("a kinematic run needs a controller (command(state, t) -> Command(velocity=...))")
    built = KinematicSystem(system, controller, control_dt) if isinstance(system, Robot) else \
        system.system(controller, dt=dt, control_dt=control_dt)
    q, x = built.initial_state(q0, v0)
    arrays, wall_time = run_loop(built, q, x, steps=steps, dt=dt, integrator=integrator, recorders=recorders,
                                 progress=progress, desc="simulate")
    if task is not None:  # from the stored rows, in one pass: they replace a system's own end-effector series
        arrays.update(TaskSeries(built.robot, task, desired)(arrays["t"], arrays["q"]))
    return SimulationResult.from_rows(arrays, built.series_info(), robot=built.robot,
                                      axes=task.axes if task is not None else (), integrator=integrator, dt=dt,
                                      wall_time=wall_time)
