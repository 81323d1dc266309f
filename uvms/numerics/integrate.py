"""Fixed-step integrators on the configuration manifold, and the step-count bound every run shares.

A state is a configuration q (nq,) on the manifold of the Pinocchio model and a
vector part x (m,) (empty for a kinematic run, the velocity v (nv,) for the
dynamic plant). Its rate is given by ``rate(t, q, x) -> (w, xdot)``, w (nv,) the
velocity that moves q (a tangent vector at q, in Pinocchio's local convention)
and xdot (m,) the derivative of x.

Two schemes, one implementation each:

* explicit Euler: q+ = integrate(q, w dt), x+ = x + dt xdot;
* RK4 in the Runge-Kutta-Munthe-Kaas form: the configuration stages are tangent
  vectors xi at q_k, mapped with ``pin.integrate`` and pulled back with
  ``pin.dIntegrate`` (xi' = dexp^-1 w), so that a continuous-time law is
  integrated to fourth order on the manifold and not only in a chart (a
  quaternion stays unit).

This module sits below the dynamics, the controllers and the simulation loop
(:mod:`uvms.sim.loop`), which all use it.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pinocchio as pin

from ..errors import StepCountError, UVMSError
from ._kernels import Kernel
from .lapack import singular_system

#: The argument dIntegrate differentiates: the tangent vector (read once, not at every stage).
ARG1 = pin.ArgumentPosition.ARG1
#: The rate of a state: (t [s], q (nq,), x (m,)) -> (w (nv,) tangent at q, xdot (m,)).
Rate = Callable[[float, np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]
#: The schemes, by the name scenarios (``simulation.integrator``) and the front-ends use.
INTEGRATORS = ("euler", "rk4")
#: The most steps one run may take (kinematic or dynamic). Every step is kept in memory, about 3.5 kB with the
#: CSV text written at the end, so a run of MAX_STEPS takes about 0.7 GB; hoang2011's 190 s at dt = 1 ms is
#: 190,000 steps (the shipped scenarios take at most 9,500).
MAX_STEPS = 200_000


def check_integrator(name: str, what: str = "integrator") -> str:
    """``name`` if it is one of :data:`INTEGRATORS`.

    Args:
        name: the scheme asked for.
        what: how the caller calls the choice, for the message ("integrator", "method").

    Raises:
        UVMSError: an unknown scheme, with the valid ones.
    """
    if name not in INTEGRATORS:
        raise UVMSError(f"unknown {what} {name!r}; valid: {', '.join(INTEGRATORS)}")
    return name


def step_count(duration: float, dt: float, *, dt_name: str = "dt", duration_name: str = "duration") -> int:
    """round(duration / dt), the number of steps of a run, checked before it starts.

    Args:
        duration, dt: [s].
        dt_name, duration_name: how the caller calls them, for the message (e.g. "simulation.dt").

    Raises:
        StepCountError: dt or duration not finite and > 0, dt > duration (no step), or more than
            :data:`MAX_STEPS` steps.
    """
    try:
        dt, duration = float(dt), float(duration)
    except (TypeError, ValueError):
        raise StepCountError(f"{dt_name} and {duration_name} must be numbers [s], "
                             f"got {dt!r} and {duration!r}") from None
    if not (math.isfinite(dt) and dt > 0 and math.isfinite(duration) and duration > 0):
        raise StepCountError(f"{dt_name} and {duration_name} must be finite and > 0, got dt={dt!r}, "
                             f"duration={duration!r}")
    if dt > duration:
        raise StepCountError(f"{dt_name} = {dt:g} s is longer than {duration_name} = {duration:g} s: the run would "
                             f"have no step; choose {dt_name} <= {duration:g} s")
    ratio = duration / dt
    if not ratio <= MAX_STEPS + 0.5:
        raise StepCountError(f"{dt_name} = {dt:g} s over {duration:g} s gives {ratio:.2g} steps; at most "
                             f"{MAX_STEPS:,} are allowed (every step is kept in memory): raise {dt_name} or "
                             f"shorten {duration_name}")
    return int(round(ratio))


def euler_step(model: pin.Model, rate: Rate, t: float, q: np.ndarray, x: np.ndarray, dt: float,
               first: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """One explicit Euler step: (integrate(q, w dt), x + dt xdot) with (w, xdot) = ``first`` = rate(t, q, x).

    Args:
        model: the Pinocchio model whose configuration manifold q lives on.
        rate: unused (the signature of every step); t [s], q (nq,), x (m,), dt [s].
        first: the rate at (t, q, x), already computed by the caller.
    """
    velocity, x_rate = first
    return pin.integrate(model, q, velocity * dt), x + dt * x_rate


def rk4_step(model: pin.Model, rate: Rate, t: float, q: np.ndarray, x: np.ndarray, dt: float,
             first: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """One Runge-Kutta-Munthe-Kaas step of order 4 of (q, x).

    Args:
        model: the Pinocchio model whose configuration manifold q lives on.
        rate: (t, q, x) -> (w (nv,), xdot (m,)) at the stages.
        t: [s]; q: (nq,); x: (m,); dt: [s].
        first: the rate at (t, q, x), already computed by the caller (the first stage).

    Returns:
        (q+ (nq,), x+ (m,)) at t + dt.
    """
    half = 0.5 * dt
    k1q, k1x = first
    # the stages' arguments (h k_q, x + h k_x), each stage's tangent solve xi' = dexp^-1 w (SciPy's dgesv) and the
    # weighted sums in compiled calls after Pinocchio's: numpy's and LAPACK's numbers, about twenty numpy calls and
    # three LAPACK calls fewer (a kinematic run's x is empty: its loops over x run no iteration)
    stage_inputs_into = _STAGE_INPUTS.function or _STAGE_INPUTS.load()
    tangent_stage_into = _TANGENT_STAGE.function or _TANGENT_STAGE.load()
    nv, m = len(k1q), len(x)
    xi, x_stage = np.empty(nv), np.empty(m)  # new at every stage: a stage's rate may keep views of them
    stage_inputs_into(half, k1q, x, k1x, xi, x_stage)
    k_q, k_x = [k1q], [k1x]
    for time_, next_h in ((t + half, half), (t + half, dt)):  # stages 2 and 3, each giving the next one's arguments
        velocity, x_rate = rate(time_, pin.integrate(model, q, xi), x_stage)
        jacobian, q_rate = pin.dIntegrate(model, q, xi, ARG1), np.empty(nv)
        xi, x_stage = np.empty(nv), np.empty(m)
        check_tangent_solve(tangent_stage_into(jacobian, velocity, next_h, x, x_rate, q_rate, xi, x_stage), nv)
        k_q.append(q_rate)
        k_x.append(x_rate)
    velocity, x_rate = rate(t + dt, pin.integrate(model, q, xi), x_stage)
    tangent, x_next = np.empty(nv), np.empty(m)
    check_tangent_solve((_TANGENT_SUMS.function or _TANGENT_SUMS.load())(
        pin.dIntegrate(model, q, xi, ARG1), velocity, dt / 6.0, *k_q, *k_x, x_rate, x, np.empty(nv), tangent, x_next),
        nv)
    return pin.integrate(model, q, tangent), x_next


#: The compiled arithmetic of a step (:mod:`uvms.numerics._kernels.runge_kutta`), imported at the first RK4 step: numba
#: loads there (a kinematic run's solver has loaded it already), not with this module.
_STAGE_INPUTS = Kernel("runge_kutta", "stage_inputs_into")
_TANGENT_STAGE = Kernel("runge_kutta", "tangent_stage_into")
_TANGENT_SUMS = Kernel("runge_kutta", "tangent_sums_into")


def check_tangent_solve(info: int, size: int) -> None:
    """Raise NumericalError when LAPACK's dgesv of a stage's (size, size) tangent system gave ``info`` != 0 (dIntegrate
    singular)."""
    if info != 0:
        raise singular_system(size, info)


#: The step of each scheme.
STEPS: dict[str, Callable[..., tuple[np.ndarray, np.ndarray]]] = {"euler": euler_step, "rk4": rk4_step}


def stage_times(steps: int, dt: float, integrator: str) -> list[float]:
    """The times [s] at which a run of ``steps`` steps of dt [s] from 0 evaluates its rate, computed as the loop
    and the steps compute them (t = k dt; RK4's t + dt/2 and t + dt, which need not equal the next k dt), so that
    a table of a trajectory at these times holds every time the run asks for."""
    starts = [k * dt for k in range(steps + 1)]
    if check_integrator(integrator) == "euler":
        return starts
    half = 0.5 * dt
    return starts + [t + half for t in starts[:-1]] + [t + dt for t in starts[:-1]]
