"""The MPC's prediction model: the plant's own equations of motion with thrusts and arm commands as inputs, and
their analytical derivatives.

Inputs u = [f (n,), c (n_arm,)]: the thrusts f [N] act on the vehicle through the allocation matrix B (6, n) as the
body wrench B f at the base frame; c [rad/s or m/s] are the arm's joint-velocity commands, which the servos follow
with qdd_m = (c - qd_m) / tau (:class:`uvms.dynamics.plant.plant.Plant`). The acceleration is the plant's
(:meth:`~uvms.dynamics.plant.plant.Plant.dynamics`: the same numbers, the hydrodynamics included), so a prediction
with the plant's integrator and the plant's current is the plant's step. The thrusters' first-order lag is not in
the prediction (the commanded thrust is taken as the thrust; the controller inverts the lag over its period). An
estimated constant wrench on the vehicle (``disturbance``: what an unknown current or a model error leaves) adds to
the thrusters'; being constant in the base frame it changes no derivative.

Derivatives. With the hydrodynamic wrench f_l(q, v, a) of each link (its frame; plant docstring) the inverse
dynamics is ID(q, v, a) = rnea(q, v, a, fext = f) = Mbar a + nbar, and the base rows hold ID_b = (J_base^T B f)_b
with a_m prescribed. Hence, Mbar_bb the vehicle block,

    da_b/dq = -Mbar_bb^-1 dID_b/dq,   da_b/dv = -Mbar_bb^-1 (dID_b/dv + Mbar_bm da_m/dv),   da_m/dv_m = -I / tau

dID = Pinocchio's ``computeRNEADerivatives`` with the wrenches held in their frames, minus sum_l J_l^T df_l, where
f_l's change is formed from the links' velocity and acceleration derivatives (``getFrameVelocityDerivatives``,
``getFrameAccelerationDerivatives``) and the rotation's (the current and the buoyancy turn with the link):

    f_l = -M_A (A_l + [w x c_l; 0]) - C_A(nu_r) nu_r - D(nu_r) nu_r + B_l [e_l; r_b x e_l]
    c_l = R_l^T v_c,  e_l = R_l^T e_z,  nu_r = nu_l - [c_l; 0],  d c_l = [c_l]x J_l,w dq  (likewise e_l)

with A_l = J_l a + Jdot_l v the link's spatial acceleration. No finite differences; tests check these against them.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ...dynamics.plant.added_mass import LOCAL
from ...dynamics.plant.plant import Plant


class PlantPrediction:
    """The plant's acceleration a(q, v, u) and its derivatives, u = [thrusts f (n,) [N], arm commands c (n_arm,)].

    Args:
        plant: the plant (its model, hydrodynamics, current, gravity, servo time constant: its own choices).
        matrix: B (6, n) the thrusters' allocation matrix (:func:`uvms.dynamics.thrusters.thrusters.allocation_matrix`).
    """

    def __init__(self, plant: Plant, matrix: np.ndarray) -> None:
        self.plant, self.model, self.matrix = plant, plant.model, np.asarray(matrix, dtype=float)
        self.nb, self.nv, self.n_arm, self.n = plant.nb, plant.model.nv, plant.n_arm, self.matrix.shape[1]
        self.nu = self.n + self.n_arm
        self._fk = self.model.createData()  # forward-kinematics derivatives
        self._id = self.model.createData()  # inverse-dynamics derivatives
        data = self.model.createData()
        pin.computeJointJacobians(self.model, data, pin.neutral(self.model))
        # the thrusters' generalized forces J_base^T B (nv, n): a frame on the vehicle's joint, constant in q
        base = pin.getFrameJacobian(self.model, data, plant.base_frame, LOCAL)
        self.thrust_map = base.T @ self.matrix
        self._base_block = base[:, :self.nb]  # the base frame's twist from the vehicle joint's velocity (6, nb)
        stacked = plant.stacked_links
        self._current = plant.current
        self._buoyancy = stacked.buoyancy if plant.buoyant else np.zeros(stacked.count)  # (L,) [N]
        #: an estimated constant wrench (6,) [N, N m] on the vehicle (base frame, FLU), added to the thrusters'
        self.disturbance = np.zeros(6)

    def wrench_of(self, generalized: np.ndarray) -> np.ndarray:
        """The base-frame wrench (6,) whose generalized force on the vehicle's coordinates is ``generalized`` (nb,)."""
        return np.linalg.lstsq(self._base_block.T, generalized, rcond=None)[0]

    def split(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(thrusts f (n,) [N], arm commands c (n_arm,)) of u (nu,)."""
        return u[:self.n], u[self.n:]

    def evaluate(self, q: np.ndarray, v: np.ndarray, u: np.ndarray):
        """The plant's dynamics (:class:`uvms.dynamics.plant.system.PlantDynamics`) at (q, v) under u (nu,)."""
        thrusts, arm = self.split(u)
        return self.plant.dynamics(q, v, arm, self.matrix @ thrusts + self.disturbance)

    def acceleration(self, q: np.ndarray, v: np.ndarray, u: np.ndarray) -> np.ndarray:
        """v' (nv,) at (q, v) under u (nu,)."""
        return self.evaluate(q, v, u).acceleration

    def inverse_dynamics_derivatives(self, q: np.ndarray, v: np.ndarray,
                                     a: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(ID (nv,), dID/dq (nv, nv), dID/dv (nv, nv)) of ID(q, v, a) = Mbar a + nbar, the hydrodynamics included
        (tangent-space derivatives in q, as ``pin.integrate`` moves it)."""
        from .kernel import link_wrench_derivatives  # numba: loaded when a prediction is first differentiated

        model, plant, fk = self.model, self.plant, self._fk
        stacked = plant.stacked_links
        pin.computeForwardKinematicsDerivatives(model, fk, q, v, a)
        count = stacked.count
        velocity_dq, jacobians = np.empty((count, 6, self.nv)), np.empty((count, 6, self.nv))
        acceleration_dq, acceleration_dv = np.empty((count, 6, self.nv)), np.empty((count, 6, self.nv))
        accelerations, rotations = np.empty((count, 6)), np.empty((count, 3, 3))
        for index, frame in enumerate(stacked.frames):
            velocity_dq[index], acceleration_dq[index], acceleration_dv[index], jacobians[index] = \
                pin.getFrameAccelerationDerivatives(model, fk, frame, LOCAL)
            accelerations[index] = pin.getFrameAcceleration(model, fk, frame, LOCAL).vector
            rotations[index] = pin.updateFramePlacement(model, fk, frame).rotation
        wrenches = np.empty((count, 6))
        d_dq, d_dv = np.zeros((self.nv, self.nv)), np.zeros((self.nv, self.nv))
        link_wrench_derivatives(velocity_dq, jacobians, acceleration_dq, acceleration_dv, v, accelerations, rotations,
                                stacked.added_mass, stacked.linear_damping, stacked.forward_damping,
                                stacked.quadratic_damping, self._buoyancy, stacked.center_of_buoyancy, self._current,
                                plant.added_mass, plant.damping,
                                wrenches, d_dq, d_dv)
        # the wrenches in their joints' frames, where rnea takes them (held there for its derivatives)
        fext = [pin.Force.Zero() for _ in range(model.njoints)]
        for index, (frame, joint) in enumerate(zip(stacked.frames, stacked.joints)):
            fext[joint] += model.frames[frame].placement.act(pin.Force(wrenches[index]))
        dtau_dq, dtau_dv, _ = pin.computeRNEADerivatives(model, self._id, q, v, a, fext)
        return self._id.tau.copy(), d_dq + dtau_dq, d_dv + dtau_dv

    def derivatives(self, q: np.ndarray, v: np.ndarray, u: np.ndarray, a: np.ndarray,
                    mass: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(da/dq (nv, nv), da/dv (nv, nv), da/du (nv, nu)) at (q, v, u), a = its acceleration (nv,), mass = Mbar.

        Args:
            q, v, u: the state and the input; a, mass: what :meth:`evaluate` gave there.
        """
        nb, tau = self.nb, self.plant.motor_time_constant
        _, did_dq, did_dv = self.inverse_dynamics_derivatives(q, v, a)
        base, coupling = mass[:nb, :nb], mass[:nb, nb:]
        da_dq, da_dv, da_du = np.zeros((self.nv, self.nv)), np.zeros((self.nv, self.nv)), np.zeros((self.nv, self.nu))
        arm = np.eye(self.n_arm) / tau
        da_dv[nb:, nb:] = -arm
        da_du[nb:, self.n:] = arm
        stacked = np.hstack([-did_dq[:nb], -(did_dv[:nb] + coupling @ da_dv[nb:]),
                             self.thrust_map[:nb], -coupling @ arm])
        solved = np.linalg.solve(base, stacked)
        nv = self.nv
        da_dq[:nb], da_dv[:nb] = solved[:, :nv], solved[:, nv:2 * nv]
        da_du[:nb] = solved[:, 2 * nv:]
        return da_dq, da_dv, da_du
