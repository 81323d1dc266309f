"""The held-out check of an identification: the vehicle's twist simulated from the log's wrench and arm motion.

From the first smoothed state of the held-out segment, the vehicle's velocity is integrated (RK4 on the
manifold, :func:`uvms.numerics.integrate.rk4_step`, at the log's step) under the logged body wrench, with the
arm's motion prescribed from the log (positions, velocities, accelerations interpolated linearly): the plant's
vehicle rows, Mbar_bb a_b = -(Mbar_bm a_m + nbar_b(q, v, wrench)) (:mod:`uvms.dynamics.plant.plant`). Nothing of the
held-out segment but its first state is fed back: an output-error check of the model, identified or prior.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ...numerics.integrate import rk4_step
from ..hydro.parameters import HydroParameters
from ..plant.plant import Plant
from .data import SmoothedStates
from .model import AXES, configurations


@dataclass(frozen=True)
class HeldOutPrediction:
    """Measured and simulated body twists (K, 6) [m/s, rad/s] at t (K,) [s] on the held-out segment."""

    t: np.ndarray
    measured: np.ndarray
    identified: np.ndarray
    prior: np.ndarray

    def metrics(self) -> dict:
        """Fit [%] per axis, 100 (1 - |y - y_sim| / |y - mean y|), of the identified and of the prior model
        (None for a model whose simulation diverged: its twists are NaN from there on)."""
        spread = np.linalg.norm(self.measured - self.measured.mean(axis=0), axis=0)
        spread = np.maximum(spread, 1e-12)

        def fit(simulated: np.ndarray) -> dict | None:
            if not np.all(np.isfinite(simulated)):
                return None  # the model diverged on the segment
            values = 100.0 * (1.0 - np.linalg.norm(self.measured - simulated, axis=0) / spread)
            return dict(zip(AXES, values.tolist()))

        return {"duration_s": float(self.t[-1] - self.t[0]), "fit_percent_identified": fit(self.identified),
                "fit_percent_prior": fit(self.prior)}


def simulate_twist(plant: Plant, states: SmoothedStates) -> np.ndarray:
    """The vehicle's body twist (K, 6) simulated over the samples of ``states`` (module docstring)."""
    q_log, v_log, a_log = configurations(plant.robot, states)
    nb, model = plant.nb, plant.model
    t = states.t

    def column_interp(time: float, values: np.ndarray) -> np.ndarray:
        return np.array([np.interp(time, t, values[:, i]) for i in range(values.shape[1])])

    def rate(time: float, q: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        q = q.copy()
        q[7:] = column_interp(time, q_log[:, 7:])
        v = np.concatenate([x, column_interp(time, v_log[:, nb:])])
        mass, bias = plant._mass_and_bias(q, v, column_interp(time, states.wrench))
        arm_acceleration = column_interp(time, a_log[:, nb:])
        acceleration = -np.linalg.solve(mass[:nb, :nb], mass[:nb, nb:] @ arm_acceleration + bias[:nb])
        return v, acceleration

    q, x = q_log[0].copy(), v_log[0, :nb].copy()
    twists = [x.copy()]
    for k in range(len(t) - 1):
        dt = t[k + 1] - t[k]
        q, x = rk4_step(model, rate, t[k], q, x, dt, rate(t[k], q, x))
        if not np.all(np.isfinite(x)):  # a diverging model: the rest is reported as not predicted
            twists += [np.full(nb, np.nan)] * (len(t) - 1 - k)
            break
        twists.append(x.copy())
    placement = plant.robot.base_placement  # the vehicle joint's twist back to the root link's axes
    return np.array([placement.actInv(pin.Motion(row)).vector for row in twists])


def predict_held_out(robot, identified: HydroParameters, prior: HydroParameters, current: np.ndarray,
                     states: SmoothedStates) -> HeldOutPrediction:
    """The held-out twists simulated with the identified and with the prior hydrodynamics."""
    simulated = [simulate_twist(Plant(robot, hydro, gravity=True, current=current), states)
                 for hydro in (identified, prior)]
    return HeldOutPrediction(states.t, states.measured_twist, *simulated)
