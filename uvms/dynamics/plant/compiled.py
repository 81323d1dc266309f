"""A plant's evaluation: Pinocchio's algorithms at (q, v), then one compiled call over what they leave in its data.

Every evaluation of :class:`uvms.dynamics.plant.plant.Plant` runs ``crba`` (M's upper triangle), ``rnea`` (h(q, v) with
gravity) and, where the links or a wrench read the kinematics, ``forwardKinematics`` (the bias accelerations Jdot v)
and ``computeJointJacobians``; one kernel of :mod:`uvms.numerics._kernels.plant_stage` reads them in place (data.J,
the joints' placements and bias accelerations as views: :class:`~uvms.dynamics.plant.data_views.JointArrays`) with the
plant's constants, the vehicle's block solved inside it with numpy's LAPACK (:mod:`uvms.numerics._kernels.solve`:
numpy's numbers).

What an integrator's stage calls is a closure over the plant's arrays and Pinocchio's functions, bound once
(:meth:`CompiledPass.actuated_stage`): a stage is Pinocchio and the kernel with a few Python calls around them (as
methods reading the same attributes at every call, a stage of the BlueROV2 + Alpha 5 took about 3 us more of its ~20).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pinocchio as pin

from ...numerics.lapack import singular_system
from .added_mass import StackedLinks
from .data_views import JointArrays
from .system import PlantDynamics

#: (q (nq,), v (nv,), kinematics) -> what a kernel of plant_stage reads first: (M's upper triangle (nv, nv), h (nv,),
#: data.J (6, nv), the joints' placements (njoints, 12), their bias accelerations (njoints, 6), ints, floats).
Inputs = Callable[[np.ndarray, np.ndarray, bool], tuple]


class CompiledPass:
    """The compiled evaluation of one plant (made at its first evaluation: numba loads here).

    Args:
        model, data, dynamics_data: the plant's model and its two Data (kinematics; crba and rnea), which the pass
            writes.
        joint_arrays: the views of ``data`` the kernels read.
        stacked, flags, current, nb, base_frame, motor_time_constant: the plant's links, its flags (added mass,
            damping, moving fluid, buoyancy), the current (3,) [m/s], the vehicle's velocity entries, its root link's
            frame (where a body wrench acts) and tau [s] (:func:`~uvms.numerics._kernels.plant_stage.plant_constants`).
    """

    def __init__(self, model: pin.Model, data: pin.Data, dynamics_data: pin.Data, joint_arrays: JointArrays,
                 stacked: StackedLinks, flags: np.ndarray, current: np.ndarray, nb: int, base_frame: pin.Frame,
                 motor_time_constant: float) -> None:
        from ...numerics._kernels import plant_stage  # numba: loaded with the plant's first evaluation

        self.kernels, self.nb, self.nv = plant_stage, nb, model.nv
        ints, floats = plant_stage.plant_constants(model, data, stacked, flags, current, nb, base_frame,
                                                   motor_time_constant)
        nv = model.nv
        self.scratch = np.empty((nv, nv)), np.empty(nv)  # Mbar, nbar of an integrator's stage (not returned)
        # none of a (n,) or a (k, 6) argument: no wrench, no torques, no second velocity
        self.empty, self.empty_rows = np.zeros(0), np.zeros((0, 6))
        rows = joint_arrays.read()[1]  # the joints' bias accelerations as the kernels read them (njoints, 6)
        self.empty_rows.flags.writeable = rows.flags.writeable  # (typed as the Data's rows)
        # the second velocity's rows, copied before the first velocity's calls overwrite the Data: a buffer, and the
        # view of it the kernel reads, typed as the Data's rows (read-only where they are views: one specialization)
        buffer = np.empty_like(rows, order="C")
        typed = buffer.view()
        typed.flags.writeable = rows.flags.writeable
        self._second_rows = buffer, typed
        self.inputs = _inputs(model, data, dynamics_data, joint_arrays, ints, floats, bool(stacked.count))
        self.second_inputs = _second_inputs(model, data, dynamics_data, joint_arrays, bool(stacked.count))

    def accelerations_into(self, q: np.ndarray, v: np.ndarray, command: np.ndarray, body_wrench: np.ndarray | None,
                           out: np.ndarray | None, mass: np.ndarray, bias_forces: np.ndarray,
                           torque: np.ndarray) -> np.ndarray:
        """v' (nv,) into ``out`` when given (else a new array), Mbar into ``mass``, nbar into ``bias_forces``, the motor
        torques of v' into ``torque`` (n_arm,; size 0: none asked)
        (:func:`uvms.numerics._kernels.plant_stage.accelerations_into`).

        Raises:
            NumericalError: the vehicle's block is singular or its acceleration not finite.
        """
        acceleration = np.empty(len(v)) if out is None else out  # [base; arm], filled in place
        if not self.kernels.accelerations_into(*self.inputs(q, v, body_wrench is not None), v, command,
                                               self.empty if body_wrench is None else body_wrench, mass,
                                               bias_forces, acceleration, torque):
            raise singular_system(self.nb)
        return acceleration

    def actuated_rate_into(self, q: np.ndarray, x: np.ndarray, arm: np.ndarray, thrust_command: np.ndarray,
                           matrix: np.ndarray, time_constants: np.ndarray, extra: np.ndarray, wrench: np.ndarray,
                           rates: np.ndarray, torques: bool) -> PlantDynamics | None:
        """[v'; f'] into ``rates`` at (q, x = [v; f; ...]) (the fins' part left), B f + ``extra`` into ``wrench``
        (:func:`uvms.numerics._kernels.plant_stage.actuated_rate_into`); with ``torques`` the motor torques of its v'
        in the same call and the PlantDynamics (v' a view of ``rates``, Mbar and the torques new arrays), else None
        (Mbar and nbar in the pass's own buffers).

        Raises:
            NumericalError: as :meth:`accelerations_into`.
        """
        nv = self.nv
        mass, bias_forces = (np.empty((nv, nv)), np.empty(nv)) if torques else self.scratch
        torque = np.empty(nv - self.nb) if torques else self.empty
        if not self.kernels.actuated_rate_into(*self.inputs(q, x[:nv], True), x, arm, thrust_command, matrix,
                                               time_constants, extra, wrench, mass, bias_forces, rates, torque):
            raise singular_system(self.nb)
        return PlantDynamics(rates[:nv], torque, mass) if torques else None

    def actuated_stage(self, held: list[np.ndarray], matrix: np.ndarray,
                       time_constants: np.ndarray) -> Callable[[float, np.ndarray, np.ndarray], tuple]:
        """(t, q, x) -> (v, [v'; f']) (v the view x[:nv], the rates a new array (len(x),)) of
        :meth:`actuated_rate_into` without fins, with B (6, n) and tau (n,) [s] bound and the commands read from
        ``held`` = [u (n_arm,), sat(f_cmd) (n,) [N]] at each call (the caller's list, which it points at each step's
        commands): an integrator's stage (:data:`uvms.numerics.integrate.Rate`), made once per system (Mbar and
        nbar in the pass's own buffers)."""
        kernel, inputs, none, (mass, bias_forces) = (self.kernels.actuated_rate_into, self.inputs, self.empty,
                                                     self.scratch)
        nb, nv, empty, wrench = self.nb, self.nv, np.empty, np.empty(6)  # the wrench: written, not read

        def stage(_t: float, q: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:  # held commands: t unread
            rates, v = empty(len(x)), x[:nv]
            arm, thrust_command = held
            if not kernel(*inputs(q, v, True), x, arm, thrust_command, matrix, time_constants, none, wrench, mass,
                          bias_forces, rates, none):  # (no fins' wrench, no torques)
                raise singular_system(nb)
            return v, rates

        return stage

    def terms(self, q: np.ndarray, v: np.ndarray, body_wrench: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """(Mbar (nv, nv), nbar (nv,)) at (q, v), new arrays (:func:`uvms.numerics._kernels.plant_stage.terms_into`)."""
        nv = len(v)
        mass, bias_forces = np.empty((nv, nv)), np.empty(nv)
        self.kernels.terms_into(*self.inputs(q, v, body_wrench is not None), v,
                                self.empty if body_wrench is None else body_wrench, mass, bias_forces)
        return mass, bias_forces

    def vehicle_wrench_into(self, q: np.ndarray, v: np.ndarray, base_acceleration: np.ndarray,
                            arm_acceleration: np.ndarray, placement: tuple[np.ndarray, np.ndarray], base_frame: bool,
                            out: np.ndarray,
                            second: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None) -> None:
        """A floating vehicle's inverse dynamics at (q, v) into ``out`` (6,): Mbar and nbar, then the vehicle rows'
        body wrench at the base frame, in one compiled call after Pinocchio's
        (:func:`uvms.numerics._kernels.plant_stage.vehicle_terms_wrench_into`; ``placement``: joint_M_base as (R, p)).

        Args:
            second: None (Mbar and nbar in the pass's own buffers), or (v2 (nv,), Mbar (nv, nv), nbar2 (nv,)): Mbar
                at q and nbar at v2 written there, crba and the joint Jacobians once for both velocities (each number
                the one an evaluation at that velocity alone gives).
        """
        mass, bias_forces = self.scratch
        second_h = second_v = second_bias_forces = self.empty
        second_accelerations = self.empty_rows
        if second is not None:  # evaluated first: the first velocity's kinematics then overwrite the same Data
            second_v, mass, second_bias_forces = second
            second_h, rows = self.second_inputs(q, second_v)
            buffer, second_accelerations = self._second_rows  # (a view typed as the first's rows)
            buffer[...] = rows
        upper, h, jacobian, placements, accelerations, ints, floats = self.inputs(q, v, False)
        self.kernels.vehicle_terms_wrench_into(upper, h, jacobian, placements, accelerations, ints, floats, v, mass,
                                               bias_forces, base_acceleration, arm_acceleration, *placement,
                                               base_frame, out, second_h, second_accelerations, second_v,
                                               second_bias_forces)


def _inputs(model: pin.Model, data: pin.Data, dynamics_data: pin.Data, joint_arrays: JointArrays, ints: np.ndarray,
            floats: np.ndarray, links: bool) -> Inputs:
    """The Pinocchio part of an evaluation (:data:`Inputs`) bound to the plant's model and data: the kinematics run
    when links or a wrench read them (``kinematics``)."""
    crba, rnea, forward, jacobians = pin.crba, pin.rnea, pin.forwardKinematics, pin.computeJointJacobians
    zero, read, joint_jacobians = np.zeros(model.nv), joint_arrays.read, data.J  # data.J: a view, never reallocated
    views = read() if joint_arrays.viewed else None  # views of data.oMi, data.a: read as they are, no call

    def inputs(q: np.ndarray, v: np.ndarray, kinematics: bool) -> tuple:
        upper = crba(model, dynamics_data, q)
        h = rnea(model, dynamics_data, q, v, zero)
        if kinematics or links:
            forward(model, data, q, v, zero)  # data.a = the bias accelerations Jdot v
            jacobians(model, data)
        placements, accelerations = read() if views is None else views  # (buffers filled where not viewed)
        return upper, h, joint_jacobians, placements, accelerations, ints, floats

    return inputs


def _second_inputs(model: pin.Model, data: pin.Data, dynamics_data: pin.Data, joint_arrays: JointArrays,
                   links: bool) -> Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """(q, v) -> (h (nv,), the joints' bias accelerations (njoints, 6)) at a second velocity after an evaluation at q
    (:data:`Inputs`): rnea, and the kinematics where links read them (their placements and data.J unchanged)."""
    rnea, forward, zero, read = pin.rnea, pin.forwardKinematics, np.zeros(model.nv), joint_arrays.read

    def second(q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        h = rnea(model, dynamics_data, q, v, zero)
        if links:
            forward(model, data, q, v, zero)
        return h, read()[1]

    return second
