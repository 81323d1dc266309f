"""ONE simulation loop, for kinematic runs (state q) and the dynamic plant (state q, v), with pluggable recording.

The loop (:func:`run_loop`) integrates a *system* with one of the integrators of
:mod:`uvms.numerics.integrate` (explicit Euler, RK4 Munthe-Kaas on the manifold) and records a
row per step through the system and any number of recorders, into the one result
type :class:`uvms.sim.result.SimulationResult`. A system has

* ``model``: the Pinocchio model whose configuration manifold q lives on;
* ``sample(t, q, x)``: what is applied from (t, q, x), with ``rate`` = (w (nv,), xdot (m,)) there;
* ``stage_rate(sample)``: (t, q, x) -> (w, xdot) at the integrator's stages;
* ``record(t, q, x, sample)``: its own series of the row (a dict name -> value);
* ``check(t, q, x, dt)``: refuse a state reached at t (non-finite...).

:class:`KinematicSystem` is q' = controller velocity (x empty);
:class:`uvms.dynamics.plant.PlantSystem` is (q, v)' = (v, forward dynamics under the command).
The front-ends :func:`simulate`, :func:`simulate_plant` and :func:`simulate_gjm` build them.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..robot import kinematics
from ..control.gjm import GJMController
from ..dynamics.plant import Command, Plant, PlantSystem
from ..errors import GJMControlError, UVMSError
from ..numerics.integrate import INTEGRATORS, MAX_STEPS, STEPS, check_integrator, step_count
from ..io.progress import tqdm
from ..robot.robot import Robot
from .result import PLANT_SERIES, SERIES, SimulationResult, velocity_labels
from ..tasks.frame import FrameTask

__all__ = ["INTEGRATORS", "MAX_STEPS", "PLANT_SERIES", "SERIES", "Controller", "KinematicSystem",
           "SimulationResult", "TaskRecorder", "run_loop", "simulate", "simulate_gjm",
           "simulate_plant", "step_count", "velocity_labels"]

#: Every controller takes (t [s], q (nq,), v): the arguments of a plant command too (``Command``), v being the
#: plant's velocity (nv,), or None in a kinematic run, which has no velocity state. A kinematic controller returns
#: the velocity v (nv,) to integrate and a diagnostics object (a VelocityResult or PriorityResult: fields
#: sigma_min, damping, limits_active); a plant command returns the joint-velocity command u (n_arm,).
Controller = Callable[[float, np.ndarray, "np.ndarray | None"], tuple[np.ndarray, object]]
#: A recorder maps (t, q, x, sample) to the series of a row, name -> value.
Recorder = Callable[[float, np.ndarray, np.ndarray, object], dict]
EMPTY = np.zeros(0)


# ------------------------------------------------------------------ the loop
def run_loop(system, q0: np.ndarray, x0: np.ndarray, *, steps: int, dt: float, integrator: str = "rk4",
             recorders: Sequence[Recorder] = (), progress: bool | None = None,
             desc: str = "simulate") -> tuple[dict[str, np.ndarray], float]:
    """Integrate ``system`` from (q0, x0) for ``steps`` steps of ``dt`` and record every row.

    Args:
        system: a system (module docstring); q0: (nq,); x0: (m,), checked by the caller.
        steps: the number of steps (:func:`uvms.numerics.integrate.step_count`); dt: [s].
        integrator: "euler" or "rk4".
        recorders: (t, q, x, sample) -> {name: value} after the system's own record, later ones win.
        progress: show a progress bar (None: only on a terminal); desc: its label.

    Returns:
        (the series by name, N = steps + 1 rows each, the wall time [s]).
    """
    step = STEPS[check_integrator(integrator)]
    q, x = q0, x0
    records: dict[str, list] = {}
    started = time.perf_counter()
    for k in tqdm(range(steps + 1), disable=(not progress) if progress is not None else None, desc=desc,
                  unit="step", leave=False):
        t = k * dt
        sample = system.sample(t, q, x)
        row = {"t": t, "q": q.copy(), **system.record(t, q, x, sample)}
        for recorder in recorders:
            row.update(recorder(t, q, x, sample))
        for name, value in row.items():
            records.setdefault(name, []).append(value)
        if k == steps:
            break
        q, x = step(system.model, system.stage_rate(sample), t, q, x, dt, sample.rate)
        system.check(t + dt, q, x, dt)
    return {name: np.array(values) for name, values in records.items()}, time.perf_counter() - started


# ------------------------------------------------------------------ kinematic runs
@dataclass(frozen=True)
class KinematicSample:
    """The controller's velocity at the start of a step: rate = (v (nv,), empty) and its diagnostics."""

    rate: tuple[np.ndarray, np.ndarray]
    info: object


class KinematicSystem:
    """q' = v from a kinematic controller (t, q, None) -> (v, diagnostics); no vector state.

    Args:
        robot: the model; controller: (t, q, None) -> (v (nv,), diagnostics with sigma_min, damping,
            optionally limits_active).
    """

    def __init__(self, robot: Robot, controller: Controller) -> None:
        self.robot, self.model, self.controller = robot, robot.model, controller

    def sample(self, t: float, q: np.ndarray, x: np.ndarray) -> KinematicSample:
        """The velocity applied from q at t.

        Raises:
            UVMSError: a non-finite velocity.
        """
        v, info = self.controller(t, q, None)
        if not np.all(np.isfinite(v)):
            raise UVMSError(f"the controller returned a non-finite velocity at t = {t:.6g} s")
        return KinematicSample((v, EMPTY), info)

    def stage_rate(self, sample: KinematicSample) -> Callable[[float, np.ndarray, np.ndarray], tuple]:
        """(t, q, x) -> (controller velocity, empty) at the stages (the controller's ``velocity(t, q)`` when it
        has one: the same v without the diagnostics no one reads there)."""
        velocity = getattr(self.controller, "velocity", None)
        if velocity is not None:
            return lambda t, q, x: (velocity(t, q), EMPTY)
        controller = self.controller
        return lambda t, q, x: (controller(t, q, None)[0], EMPTY)

    def record(self, t: float, q: np.ndarray, x: np.ndarray, sample: KinematicSample) -> dict:
        """v and the solver's diagnostics of a row."""
        info = sample.info
        sigma_min = info.sigma_min  # one number, or one per level (task priority)
        return {"v": sample.rate[0].copy(),
                "sigma_min": sigma_min if isinstance(sigma_min, float) else float(np.min(sigma_min)),
                "damping": float(info.damping), "limits_active": len(getattr(info, "limits_active", ()))}

    def check(self, t: float, q: np.ndarray, x: np.ndarray, dt: float) -> None:
        """Nothing to refuse: the velocity was checked when sampled."""


class TaskRecorder:
    """The task series of a row: end-effector pose, desired pose and the errors on the task axes.

    Args:
        robot: the model; task: the end-effector task (its frame, axes and orientation error).
        desired: t -> desired pose of the task frame.
        positions: also record ee_position and desired_position (False when another recorder does).
    """

    def __init__(self, robot: Robot, task: FrameTask, desired: Callable[[float], pin.SE3], positions: bool = True):
        self.robot, self.task, self.desired, self.positions = robot, task, desired, positions
        self.position_rows = [r for r in task.rows if r < 3]
        self.orientation_rows = [r for r in task.rows if r >= 3]

    def __call__(self, t: float, q: np.ndarray, x: np.ndarray, sample: object) -> dict:
        task = self.task
        # q comes from pin.integrate in the loop (checked once at its start): Robot.fk would check it at every row
        pose = kinematics.frame_pose(self.robot.model, self.robot.data, q, task.frame_id)
        target = self.desired(t)
        full_error = task.full_error_between(target, pose)
        row = {"ee_rpy": pin.rpy.matrixToRpy(pose.rotation), "desired_rpy": pin.rpy.matrixToRpy(target.rotation),
               "task_error": full_error[task.rows],
               "position_error": float(np.linalg.norm(full_error[self.position_rows])),
               "orientation_error": float(np.linalg.norm(full_error[self.orientation_rows]))}
        if self.positions:
            row.update(ee_position=pose.translation.copy(), desired_position=target.translation.copy())
        return row


def simulate(
    robot: Robot,
    controller: Controller,
    q0: np.ndarray,
    *,
    duration: float,
    dt: float,
    task: FrameTask,
    desired: Callable[[float], pin.SE3],
    integrator: str = "rk4",
    progress: bool | None = None,
    recorders: Sequence[Recorder] = (),
) -> SimulationResult:
    """Integrate q' = controller(t, q, None) from q0 for ``duration`` with step ``dt``.

    Args:
        robot: the model.
        controller: (t, q, None) -> (v, diagnostics) (the order of every controller, see ``Controller``).
        q0: initial configuration (nq,).
        duration, dt: [s]; the number of steps is round(duration / dt), at least 1 and at most
            :data:`MAX_STEPS` (:func:`step_count`).
        task: the end-effector task (its frame and axes define the recorded errors).
        desired: t -> desired pose of the task frame (for the record).
        integrator: "euler" or "rk4".
        progress: show a progress bar (None: only on a terminal).
        recorders: more series per row, after the task's (e.g. the inequalities of
            :class:`uvms.scenario.inequalities.ObjectiveRecorder`); their names must be fields of SimulationResult.
    """
    check_integrator(integrator)
    steps = step_count(duration, dt)
    q = robot.check_configuration(q0).copy()
    arrays, wall_time = run_loop(KinematicSystem(robot, controller), q, EMPTY, steps=steps, dt=dt,
                                 integrator=integrator, recorders=[TaskRecorder(robot, task, desired), *recorders],
                                 progress=progress, desc="simulate")
    return SimulationResult(**arrays, robot=robot, axes=task.axes, wall_time=wall_time, integrator=integrator, dt=dt)


# ------------------------------------------------------------------ plant runs
def simulate_plant(
    plant: Plant,
    q0: np.ndarray,
    v0: np.ndarray | None,
    command: Command | np.ndarray | None,
    duration: float,
    dt: float,
    *,
    integrator: str = "rk4",
    hold: bool = False,
    progress: bool | None = None,
    recorders: Sequence[Recorder] = (),
) -> SimulationResult:
    """Integrate the plant from (q0, v0) for ``duration`` with a fixed step ``dt``.

    RK4 is the Runge-Kutta-Munthe-Kaas scheme of order 4 (:mod:`uvms.numerics.integrate`): the
    configuration stages live in the tangent space at q_k and are mapped with
    ``pin.integrate`` / ``pin.dIntegrate``, so the quaternion stays unit and the order
    is 4 on the manifold. "euler" is explicit Euler, for comparison.

    Args:
        plant: the Plant.
        q0: initial configuration (nq,); v0: initial velocity (nv,) (None: rest).
        command: (t, q, v) -> joint-velocity command (n_arm,), a constant (n_arm,), or None (zero).
        duration, dt: [s]; the number of steps is round(duration / dt), at least 1 and at most
            :data:`uvms.numerics.integrate.MAX_STEPS`.
        integrator: "rk4" (Runge-Kutta-Munthe-Kaas) or "euler".
        hold: sample the command once per step and hold it (a digital
            controller at 1/dt); default: evaluate it at every stage.
        progress: show a progress bar (None: only on a terminal).
        recorders: more series per row, (t, q, v, sample) -> {name: value}.

    Returns:
        A SimulationResult with N = steps + 1 rows and the plant series (command, joint_torque,
        kinetic_energy, potential_energy, momentum).

    Raises:
        UVMSError: bad arguments, a command of the wrong size or non-finite, a state
            that becomes non-finite (step too large).
    """
    integrator = check_integrator(integrator, "integrator")
    steps = step_count(duration, dt)  # checked before anything runs; the same bounds as every run
    robot = plant.robot
    q = robot.check_configuration(q0).copy()
    v = np.zeros(plant.model.nv) if v0 is None else robot.check_velocity(v0).copy()
    arrays, wall_time = run_loop(PlantSystem(plant, command, hold), q, v, steps=steps, dt=dt, integrator=integrator,
                                 recorders=recorders, progress=progress, desc="plant")
    if arrays["command"].ndim == 1:  # no arm
        arrays["command"] = arrays["command"].reshape(len(arrays["t"]), 0)
        arrays["joint_torque"] = arrays["joint_torque"].reshape(len(arrays["t"]), 0)
    return SimulationResult(**arrays, robot=robot, plant=plant, dt=dt, integrator=integrator, wall_time=wall_time)


def simulate_gjm(
    plant: Plant,
    controller: GJMController,
    q0: np.ndarray,
    duration: float,
    dt: float,
    *,
    control_dt: float = 0.0,
    integrator: str = "rk4",
    progress: bool | None = None,
    task: FrameTask | None = None,
) -> SimulationResult:
    """Drive the plant with the GJM controller from rest at q0 and record the tracking.

    Args:
        plant: the free-floating plant (its robot must be the controller's model).
        controller: the GJM controller.
        q0: initial configuration (nq,); the system starts at rest (zero momentum).
        duration, dt: [s], integration step.
        control_dt: 0 (default): a continuous controller, evaluated at every
            integrator stage; > 0: a digital one, sampled every ``control_dt`` [s]
            (a multiple of dt) and held in between.
        integrator: "rk4" (Runge-Kutta-Munthe-Kaas) or "euler".
        progress: a progress bar (None: only on a terminal).
        task: a ``FrameTask`` on the controlled frame: also record its series (ee_rpy, task_error,
            orientation error; position_error from its axes) as ``uvms run`` saves them; None: the
            position error is |p_d - p| over the controller's position axes.

    Returns:
        A SimulationResult with the plant series, the tracking series (ee_position, desired_position,
        ee_velocity, desired_velocity, rates, sigma_min, damping) and, with ``task``, the task series.

    Raises:
        GJMControlError: control_dt not 0 nor a positive multiple of dt; plant and controller on different models.
        UVMSError: from the plant (non-finite state, bad sizes).
    """
    if plant.robot.model.nv != controller.model.nv or plant.robot.model.nq != controller.model.nq:
        raise GJMControlError("the plant and the controller must use the same robot model")
    control_dt = float(control_dt)
    command, hold = controller, False
    if control_dt != 0.0:
        ratio = control_dt / dt
        if not (np.isfinite(ratio) and ratio >= 1 - 1e-9 and abs(ratio - round(ratio)) < 1e-6):
            raise GJMControlError(f"control_dt must be 0 (continuous) or a positive multiple of dt = {dt:g} s, "
                                  f"got {control_dt!r}")
        every = int(round(ratio))
        held: dict[str, np.ndarray] = {}

        def command(t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:  # called once per step (hold=True)
            step = int(round(t / dt))
            if step % every == 0 or "u" not in held:
                held["u"] = controller(t, q, v)
            return held["u"]

        hold = True
    recorders: list[Recorder] = [lambda t, q, v, sample: controller.tracking(t, q, v)]
    if task is not None:
        recorders.append(TaskRecorder(controller.robot, task, lambda t: controller.reference(t).pose, positions=False))
    result = simulate_plant(plant, q0, None, command, duration, dt, integrator=integrator, hold=hold,
                            progress=progress, recorders=recorders)
    result.controller, result.control_dt = controller, control_dt
    if task is None:
        result.position_error = result.tracking_error()
    else:
        result.axes = task.axes
        result.limits_active = np.zeros(len(result.t), dtype=int)
    return result
