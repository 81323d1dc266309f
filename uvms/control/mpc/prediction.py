"""The MPC's prediction model: the plant's own equations of motion with thrusts and arm commands as inputs, and
their analytical derivatives.

Inputs u = [f (n,), c (n_arm,)]: the thrusts f [N] act on the vehicle through the allocation matrix B (6, n) as the
body wrench B f at the base frame; c [rad/s or m/s] are the arm's joint-velocity commands, which the servos follow
with qdd_m = (c - qd_m) / tau (:class:`uvms.dynamics.plant.plant.Plant`). The acceleration is the plant's
(:meth:`~uvms.dynamics.plant.plant.Plant.dynamics` with the body wrench B f: the same bits, the hydrodynamics
included), so a prediction
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

Speed. The acceleration is the plant's call itself (its one compiled pass over the links: no second copy of the
plant's arithmetic here). For the derivatives, one Pinocchio call (``computeRNEADerivatives`` without fext) gives
every joint's world Jacobian columns and their rate; the links' Jacobians (the plant's own pass over them,
:func:`uvms.numerics._kernels.hydro.frame_jacobian_into`), accelerations, their derivatives and the wrenches are
formed from them in one compiled pass (:mod:`uvms.control.mpc.kernel`), the wrenches' part of dID/dq that rnea would
add for an fext among them. Arrays are preallocated per prediction, and the plant's own pin.Data are used: a
prediction is not to be shared between threads.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ...dynamics.plant.added_mass import LOCAL
from ...dynamics.plant.plant import Plant
from ...dynamics.plant.system import PlantDynamics
from ...errors import UVMSError


class PlantPrediction:
    """The plant's acceleration a(q, v, u) and its derivatives, u = [thrusts f (n,) [N], arm commands c (n_arm,)].

    Args:
        plant: the plant (its model, hydrodynamics, current, gravity, servo time constant: its own choices).
        matrix: B (6, n) the thrusters' allocation matrix (:func:`uvms.dynamics.thrusters.thrusters.allocation_matrix`).

    Raises:
        UVMSError: a model with mimic joints (Pinocchio's derivatives refuse them).
    """

    def __init__(self, plant: Plant, matrix: np.ndarray) -> None:
        self.plant, self.model, self.matrix = plant, plant.model, np.asarray(matrix, dtype=float)
        model = self.model
        if plant.robot.mimic_joint_names:
            raise UVMSError(f"{plant.robot.name}: the MPC's prediction does not take mimic joints "
                            f"({', '.join(plant.robot.mimic_joint_names)}); Pinocchio's derivatives refuse them")
        self.nb, self.nv, self.n_arm, self.n = plant.nb, model.nv, plant.n_arm, self.matrix.shape[1]
        self.nu = self.n + self.n_arm
        self._kinematics = model.createData()  # rnea derivatives: J, dJ, placements
        data = model.createData()
        pin.computeJointJacobians(model, data, pin.neutral(model))
        # the thrusters' generalized forces J_base^T B (nv, n): a frame on the vehicle's joint, constant in q
        base = pin.getFrameJacobian(model, data, plant.base_frame, LOCAL)
        self.thrust_map = base.T @ self.matrix
        self._base_block = base[:, :self.nb]  # the base frame's twist from the vehicle joint's velocity (6, nb)
        stacked = plant.stacked_links
        self._current = plant.current
        self._buoyancy = stacked.buoyancy if plant.buoyant else np.zeros(stacked.count)  # (L,) [N]
        # the links' joints' placements read once per evaluation (slots), the links' walks over data.J (the plant's)
        self._placed = sorted(set(stacked.joints))
        self._slots = np.array([self._placed.index(joint) for joint in stacked.joints], dtype=np.int64)
        self._placements = np.zeros((len(self._placed), 4, 4))
        from ...numerics._kernels.hydro import frame_jacobian_program  # numba: loaded when a prediction is built
        from . import kernel  # compiled (or read from the cache) at first use

        walks = [frame_jacobian_program(model, data, joint) for joint in stacked.joints]
        self._starts = np.cumsum([0] + [len(walk) for walk in walks]).astype(np.int64)
        self._programs = np.concatenate(walks) if walks else np.zeros((0, 3), dtype=np.int64)
        owner = [0] * model.nv  # the joint of each velocity column
        for joint in range(1, model.njoints):
            owner[model.idx_vs[joint]:model.idx_vs[joint] + model.nvs[joint]] = [joint] * model.nvs[joint]
        self._descends = np.array([[owner[k] != owner[i] and owner[i] in model.supports[owner[k]]
                                    for i in range(model.nv)] for k in range(model.nv)], dtype=np.bool_)
        self._kernel = kernel
        #: an estimated constant wrench (6,) [N, N m] on the vehicle (base frame, FLU), added to the thrusters'
        self.disturbance = np.zeros(6)

    def wrench_of(self, generalized: np.ndarray) -> np.ndarray:
        """The base-frame wrench (6,) whose generalized force on the vehicle's coordinates is ``generalized`` (nb,)."""
        return np.linalg.lstsq(self._base_block.T, generalized, rcond=None)[0]

    def split(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(thrusts f (n,) [N], arm commands c (n_arm,)) of u (nu,)."""
        return u[:self.n], u[self.n:]

    def _read_placements(self, data: pin.Data) -> np.ndarray:
        placements, joints = self._placements, data.oMi
        for slot, joint in enumerate(self._placed):
            placements[slot] = joints[joint].homogeneous
        return placements

    def evaluate(self, q: np.ndarray, v: np.ndarray, u: np.ndarray) -> PlantDynamics:
        """The plant's dynamics at (q, v) under u (nu,): acceleration, motor torques, Mbar: the plant's own call
        (:meth:`uvms.dynamics.plant.plant.Plant.dynamics`) with the thrusters' and the disturbance's body wrench."""
        return self.plant.dynamics(q, v, u[self.n:], self.matrix @ u[:self.n] + self.disturbance)

    def acceleration(self, q: np.ndarray, v: np.ndarray, u: np.ndarray) -> np.ndarray:
        """v' (nv,) at (q, v) under u (nu,)."""
        return self.evaluate(q, v, u).acceleration

    def inverse_dynamics_derivatives(self, q: np.ndarray, v: np.ndarray,
                                     a: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(ID (nv,), dID/dq (nv, nv), dID/dv (nv, nv)) of ID(q, v, a) = Mbar a + nbar, the hydrodynamics included
        (tangent-space derivatives in q, as ``pin.integrate`` moves it)."""
        model, data, plant, stacked = self.model, self._kinematics, self.plant, self.plant.stacked_links
        dtau_dq, dtau_dv, _ = pin.computeRNEADerivatives(model, data, q, v, a)  # fills J, dJ, oMi too
        did_dq, did_dv, torque = np.array(dtau_dq), np.array(dtau_dv), data.tau.copy()
        self._kernel.inverse_dynamics_derivatives_into(
            data.J, data.dJ, self._read_placements(data), self._slots, self._programs, self._starts, self._descends,
            stacked.rotations, stacked.translations, stacked.added_mass, stacked.linear_damping,
            stacked.forward_damping, stacked.quadratic_damping, self._buoyancy, stacked.center_of_buoyancy,
            self._current, plant.added_mass, plant.damping, v, a, torque, did_dq, did_dv)
        return torque, did_dq, did_dv

    def derivatives(self, q: np.ndarray, v: np.ndarray, u: np.ndarray, a: np.ndarray, mass: np.ndarray,
                    out: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(da/dq (nv, nv), da/dv (nv, nv), da/du (nv, nu)) at (q, v, u), a = its acceleration (nv,), mass = Mbar.

        Args:
            q, v, u: the state and the input; a, mass: what :meth:`evaluate` gave there.
            out: arrays to write the three into (e.g. views of Crocoddyl's Fx and Fu); None: new ones.
        """
        _, did_dq, did_dv = self.inverse_dynamics_derivatives(q, v, a)
        if out is None:
            out = np.empty((self.nv, self.nv)), np.empty((self.nv, self.nv)), np.empty((self.nv, self.nu))
        self._kernel.forward_derivatives_into(mass, did_dq, did_dv, self.thrust_map, self.plant.motor_time_constant,
                                              self.nb, *out)
        return out
