"""The plant's conserved quantities at one state: its energy and its spatial momentum (rigid bodies and the fluid's
added-mass share), what the records derive from the stored states after a run
(:meth:`uvms.dynamics.plant.system.PlantSystem.derived_series`). A part of :class:`~uvms.dynamics.plant.plant.Plant`
kept in its own module: the plant inherits it and it reads the plant's own model, data and links."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ...robot.kinematics import weight_potential
from .added_mass import LinkStates


class ConservedQuantities:
    """The energy and the momentum of a :class:`~uvms.dynamics.plant.plant.Plant` (which inherits them: they read its
    model, data, settings and links)."""

    def energy(self, q: np.ndarray, v: np.ndarray) -> tuple[float, float]:
        """(kinetic, potential) energy [J] at q (nq,), v (nv,).

        Kinetic: 1/2 v^T M v + sum_l 1/2 nu_r^T M_A nu_r (the fluid's share, when
        ``added_mass``). Potential (``gravity`` on): sum m g z_com - rho g V z_cob.
        """
        mass = pin.crba(self.model, self._dynamics_data, q).copy()
        mass[self._lower] = mass.T[self._lower]  # crba fills the upper triangle
        kinetic = 0.5 * float(v @ mass @ v)
        potential = weight_potential(self.model, self._dynamics_data, q) if self.gravity else 0.0
        stacked = self._stacked
        if stacked.count and (self.added_mass or self.gravity):
            links = self._link_states(q, v)
            if self.added_mass:
                relative = links.relative[:, :, None]
                kinetic += 0.5 * float((relative.transpose(0, 2, 1) @ stacked.added_mass @ relative).sum())
            if self.gravity:  # the centres of buoyancy's heights [m]
                heights = links.positions[:, 2] + (links.rotations[:, 2, :] * stacked.center_of_buoyancy).sum(axis=1)
                potential -= float(stacked.buoyancy @ heights)
        return kinetic, potential

    def momentum(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Spatial momentum (6,) of the whole system at q (nq,), v (nv,), world frame, about the world
        origin [N s, N m s].

        [linear; angular] = sum_i X_i^* I_i v_i (rigid bodies) + sum_l X_l^* M_A,l nu_r,l
        (the fluid impulse, when ``added_mass``).
        """
        model, data = self.model, self.data
        links = self._link_states(q, v) if self.added_mass and self._stacked.count else None  # forwardKinematics
        if links is None:
            pin.forwardKinematics(model, data, q, v)
        total = pin.Force.Zero()
        for joint in range(1, model.njoints):
            total += data.oMi[joint].act(model.inertias[joint] * data.v[joint])
        momentum = total.vector.copy()
        if links is not None:  # the fluid impulse M_A nu_r of each link, its frame to the world origin
            impulse = (self._stacked.added_mass @ links.relative[:, :, None])[:, :, 0]
            linear = (links.rotations @ impulse[:, :3, None])[:, :, 0]
            momentum[:3] += linear.sum(axis=0)
            momentum[3:] += ((links.rotations @ impulse[:, 3:, None])[:, :, 0]
                             + np.cross(links.positions, linear)).sum(axis=0)
        return momentum

    def _link_states(self, q: np.ndarray, v: np.ndarray) -> LinkStates:
        """The hydrodynamic links' twists and poses at (q, v), every link at once (runs forwardKinematics)."""
        model, data, stacked = self.model, self.data, self._stacked
        pin.forwardKinematics(model, data, q, v)
        joints = stacked.joints
        twists = (stacked.motion_to_link @ np.array([data.v[joint].vector for joint in joints])[:, :, None])[:, :, 0]
        joint_rotations = np.array([data.oMi[joint].rotation for joint in joints])
        rotations = joint_rotations @ stacked.rotations  # (L, 3, 3) link to world
        positions = np.array([data.oMi[joint].translation for joint in joints]) + \
            (joint_rotations @ stacked.translations[:, :, None])[:, :, 0]
        relative = twists
        if self._moving_fluid:  # nu_r = nu - [R^T v_c; 0]
            relative = twists.copy()
            relative[:, :3] -= self._current @ rotations
        return LinkStates(twists, relative, rotations, positions)
