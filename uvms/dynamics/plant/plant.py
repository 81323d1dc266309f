"""Free-floating dynamics of a UVMS in a fluid: the plant that the kinematic controllers drive.

Model
=====
The vehicle is passive here (its thrusters, when it has some, add a body wrench B f on the
vehicle: :mod:`uvms.dynamics.plant.actuated`): the joints are actuated, and each
follows its commanded velocity through a first-order motor, qdd_m = (u - qd_m) / tau
(the joint servo of amundsen2018, tau = 100 ms). Every link l may carry Fossen's
hydrodynamics (:mod:`uvms.dynamics.hydro.hydrodynamics`), written in its own frame with nu_l = J_l v
its body twist (Pinocchio ``LOCAL``), nu_c = [R_l^T v_c; 0] the ocean current and
nu_r = nu_l - nu_c::

    f_l = - M_A nu_r' - C_A(nu_r) nu_r - (D_l + D_q |nu_r|) nu_r + g_l      (link frame)
    C_A(nu) nu = nu x* (M_A nu) = [w x a1; v x a1 + w x a2],  a = M_A nu  (Fossen 2011, eq. 6.43)
    nu_r' = J_l v' + Jdot_l v - nu_c',  nu_c' = [-w x R_l^T v_c; 0]       (constant current)
    g_l   = buoyancy rho g V (up, world) at the centre of buoyancy; the weight is Pinocchio's gravity

Summed over links with the principle of virtual work, the equations of motion are

    Mbar(q) v' + nbar(q, v) = [0; tau_m],   Mbar = M + sum_l J_l^T M_A,l J_l

where M is Pinocchio's rigid-body mass matrix (``crba``) and nbar = Pinocchio's
``rnea(q, v, 0, fext)`` with fext_l = the velocity-dependent part of f_l (all of f_l
but -M_A J_l v'). The added mass goes into the mass matrix rather than into
``fext`` because it multiplies the unknown acceleration: uuv_simulator applies
-M_A nu' with the filtered acceleration of the previous step and warns that this
can oscillate, the more so as M_A approaches the link's mass (it exceeds it for
the snake's modules); in the mass matrix it is exact.

Why not ``pin.aba``: the joint *accelerations* are prescribed (by the motor) and
the base acceleration is unknown, a hybrid problem; ABA wants all torques. And
Fossen's M_A is not a rigid-body inertia (surge and sway added masses differ, and
there are couplings no mass distribution produces), so it cannot be folded into
Pinocchio's link inertias for ABA. With M_A in Mbar the base rows give

    Mbar_bb a_b = - Mbar_bm a_m - nbar_b,     tau_m = Mbar_mb a_b + Mbar_mm a_m + nbar_m

a solve of the vehicle's 6 x 6 (3 x 3 planar) block.

Conserved quantities. With no current, damping or gravity, the base rows of Mbar v are the total momentum (rigid +
added mass) expressed in the base frame, and the joints exert only internal wrenches, so the *added-mass-augmented*
momentum sum_l X_l^* (I_l + M_A,l) nu_l is conserved; with M_A = 0 it is the rigid momentum behind the generalized
Jacobian. :func:`generalized_jacobian_added_mass` is the GJM of that augmented momentum.

Mimic joints (a gripper's second finger; ``pin.buildModelFromXML(..., mimic=True)``): q and v hold only the
driving joints' coordinates, and Pinocchio's ``crba``, ``rnea`` (with ``fext``), Jacobians and centroidal map
expand them through the mimic relation (q_mimic = scaling q_driver + offset): M = G^T M_full G and
h = G^T h_full, G (nv_full, nv) the mimic's multiplier in its driver's column (tests/dynamics/plant/test_plant_mimic.py
checks both against the model without mimics). ``computePotentialEnergy``, ``computeKineticEnergy`` and ``aba``
refuse mimic joints, so the plant calls none of them: the kinetic energy is 1/2 v^T M v, the weight's potential
-m g . c from the centre of mass (:func:`uvms.robot.kinematics.weight_potential`).

The links on the model, M_A in the mass matrix, C_A and the GJM of the augmented momentum live in
:mod:`uvms.dynamics.plant.added_mass` (importable from here too).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pinocchio as pin

from ...errors import UVMSError
from ...robot.configuration import Configuration
from ...robot.kinematics import generalized_jacobian_from_parts, mass_matrix_split
from ...robot.robot import Robot, check_robot
from ..hydro.hydrodynamics import HydroParameters, hydrodynamics_of
from .added_mass import StackedLinks, augmented_mass_matrix, resolve_links
from .command import Controller
from .compiled import CompiledPass
from .conserved import ConservedQuantities
from .data_views import JointArrays
from .settings import PlantSettings
from .system import PlantDynamics, PlantSystem


class Plant(ConservedQuantities):
    """Free-floating UVMS dynamics with Fossen hydrodynamics and first-order joint motors.

    Args:
        robot: a floating- or planar-base Robot (its model is copied, never changed).
        hydro: hydrodynamic parameters; None reads the model's (uuv_simulator block
            or ``hydrodynamics.yaml``) and uses none when it has none.
        gravity: False (default): neutral buoyancy everywhere — weight and
            buoyancy cancel on every link, no restoring forces (the idealisation of
            amundsen2018's GJM). True: the weight of every link (Pinocchio) and the
            buoyancy rho g V of the links with parameters, at their centres of
            buoyancy, hence restoring moments and net heave.
        motor_time_constant: tau [s] > 0 of the joint velocity servos.
        current: (3,) ocean current [m/s] in the world frame; None: ``hydro.current``.
        added_mass: include the links' added mass (mass matrix and C_A).
        damping: include linear and quadratic damping.

    Raises:
        UVMSError: a fixed base, tau <= 0, invalid parameters or link names.
    """

    def __init__(
        self,
        robot: Robot,
        hydro: HydroParameters | None = None,
        *,
        gravity: bool = False,
        motor_time_constant: float = 0.1,
        current: np.ndarray | None = None,
        added_mass: bool = True,
        damping: bool = True,
    ) -> None:
        check_robot(robot, "Plant")
        if robot.base_type == "fixed":
            raise UVMSError(f"{robot.name} has a fixed base: the plant needs a floating or planar vehicle")
        tau = float(motor_time_constant)
        if not (np.isfinite(tau) and tau > 0):
            raise UVMSError(f"motor_time_constant must be a finite number > 0 s, got {motor_time_constant!r}")
        hydro = hydrodynamics_of(robot, required=False) if hydro is None else hydro
        if not isinstance(hydro, HydroParameters):
            raise UVMSError(f"hydro must be HydroParameters or None, got {type(hydro).__name__}")
        if current is not None:
            hydro = hydro.with_current(current)
        self.robot = robot
        self.hydro = hydro
        self.gravity = bool(gravity)
        self.motor_time_constant = tau
        self.added_mass = bool(added_mass)
        self.damping = bool(damping)
        self.model = robot.model.copy()
        self.model.gravity = pin.Motion(np.array([0.0, 0.0, -hydro.gravity, 0.0, 0.0, 0.0]) if gravity
                                        else np.zeros(6))
        self.data = self.model.createData()  # kinematics, Jacobians
        self._dynamics_data = self.model.createData()  # crba / rnea, which overwrite kinematic quantities
        self.links = resolve_links(self.model, hydro)
        self.nb = robot.n_vehicle
        self._current = hydro.current
        self._moving_fluid = bool(np.any(hydro.current != 0.0))
        self._base_frame = self.model.getFrameId(robot.root_link)
        self._base_placement = robot.base_placement
        self._stacked = StackedLinks.of(self.links, hydro, gravity)
        self._lower = np.tril_indices(self.model.nv, -1)
        self._buoyant = self.gravity and self._stacked.buoyant
        stacked = self._stacked
        # the links' joints, each once (several links may share one), and each link's of them (damping_power's)
        self._joints = tuple(dict.fromkeys(stacked.joints))
        self._link_joint = np.array([self._joints.index(joint) for joint in stacked.joints], dtype=np.int64)
        self._flags = np.array([self.added_mass, self.damping, self._moving_fluid, self._buoyant], dtype=np.int64)
        # every joint's placement and bias acceleration in self.data, as the compiled pass reads them (views)
        self._joint_arrays = JointArrays(self.data)
        # Pinocchio's algorithms and the compiled kernels with the plant's constants, made at the first evaluation:
        # numba loads there
        self._pass: CompiledPass | None = None

    @classmethod
    def from_settings(cls, robot: Robot, settings: PlantSettings) -> Plant:
        """The plant of ``robot`` that ``settings`` describe: a rigid one in vacuum, a hydrodynamic one with the
        hydrodynamics of ``settings.hydrodynamics`` (a YAML file checked against the links) or else the model's own.

        Raises:
            UVMSError: a fixed base; a hydrodynamics file not of this model; a hydrodynamic plant of a model without
                hydrodynamic parameters (each message begins with the setting it is about).
        """
        check_robot(robot, "Plant.from_settings")
        if robot.base_type == "fixed":
            raise UVMSError(f"type = {settings.type!r} needs a floating or planar vehicle; {robot.name} has a fixed "
                            f"base (load it with a floating or planar base)")
        tau = float(settings.motor_time_constant)
        if settings.type == "rigid":
            return cls(robot, HydroParameters(source="rigid plant (no fluid)"), gravity=False, motor_time_constant=tau,
                       added_mass=False, damping=False)
        try:
            hydro = hydrodynamics_of(robot, settings.hydrodynamics) if settings.hydrodynamics else None
        except UVMSError as exc:
            raise UVMSError(f"hydrodynamics: {' '.join(str(exc).split())}") from None
        plant = cls(robot, hydro, gravity=settings.gravity, motor_time_constant=tau,
                    current=np.array(settings.current, dtype=float) if settings.current else None,
                    added_mass=settings.added_mass is not False, damping=settings.damping is not False)
        if not plant.links:
            raise UVMSError(f"type = 'hydrodynamic' needs hydrodynamic parameters, and {robot.source} has none; add "
                            f"a uuv_simulator block or hydrodynamics.yaml (see uvms.dynamics.hydro.hydrodynamics), "
                            f"or use type = 'rigid'")
        return plant

    def copy(self, *, current: np.ndarray | None = None) -> Plant:
        """A plant of the same robot, hydrodynamics and choices with buffers of its own (e.g. a controller's model),
        in ``current`` (3,) [m/s] world when given, else in this plant's."""
        return Plant(self.robot, self.hydro if current is None else self.hydro.with_current(current),
                     gravity=self.gravity, motor_time_constant=self.motor_time_constant, added_mass=self.added_mass,
                     damping=self.damping)

    def system(self, controller: Controller | None, *, dt: float, control_dt: float = 0.0) -> PlantSystem:
        """This plant under a joint-velocity command, the system :func:`uvms.sim.loop.simulate` integrates.

        Args:
            controller: a Controller sending ``Command(arm=u (n_arm,))`` (e.g. the GJM controller), or None (zero).
            dt: integration step [s]; control_dt: the command's period [s] (0: evaluated at every stage).

        Raises:
            StepCountError: control_dt not 0 nor a positive multiple of dt.
        """
        return PlantSystem(self, controller, dt=dt, control_dt=control_dt)

    # ----------------------------------------------------------------- sizes
    @property
    def n_arm(self) -> int:
        """Number of actuated joint velocities."""
        return self.model.nv - self.nb

    @property
    def base_frame(self) -> int:
        """The frame id of the vehicle's root link: where the thrusters' body wrench acts."""
        return self._base_frame

    @property
    def base_placement(self) -> pin.SE3:
        """joint_M_base: the vehicle's root link frame in its vehicle joint's frame, the plant's own (not to be
        changed; ``robot.base_placement`` looks it up and copies it at every read)."""
        return self._base_placement

    @property
    def stacked_links(self) -> StackedLinks:
        """The hydrodynamic links' parameters stacked as arrays (what the compiled terms read; not to be changed)."""
        return self._stacked

    @property
    def current(self) -> np.ndarray:
        """The ocean current (3,) [m/s], world frame (a copy)."""
        return self._current.copy()

    @property
    def buoyant(self) -> bool:
        """Whether buoyancy acts (gravity on and a link with a volume)."""
        return self._buoyant

    # -------------------------------------------------------------- dynamics
    def evaluate(self, q: np.ndarray, v: np.ndarray, command: np.ndarray) -> PlantDynamics:
        """Accelerations and motor torques at (q, v) under a joint-velocity command.

        Args:
            q: configuration (nq,); v: velocity (nv,).
            command: commanded joint velocities u (n_arm,) [rad/s or m/s].

        Raises:
            ConfigurationError: wrong sizes, non-finite values, a non-unit quaternion.
        """
        robot = self.robot
        return self.dynamics(robot.check_configuration(q), robot.check_velocity(v),
                              robot.check_velocity(command, self.n_arm, "joint-velocity command"))

    def dynamics(self, q: np.ndarray, v: np.ndarray, command: np.ndarray, body_wrench: np.ndarray | None = None,
                 out: np.ndarray | None = None) -> PlantDynamics:
        """:meth:`evaluate` unchecked, for inner loops whose inputs are checked; ``body_wrench`` (6,) [N, N m]: a wrench
        on the vehicle, FLU at :attr:`base_frame` (the thrusters'); ``out`` (nv,): where v' goes (None: a new array)."""
        nv = self.model.nv
        mass, bias_forces, torque = np.empty((nv, nv)), np.empty(nv), np.empty(nv - self.nb)  # returned: new arrays
        acceleration = self._compiled().accelerations_into(q, v, command, body_wrench, out, mass, bias_forces, torque)
        return PlantDynamics(acceleration, torque, mass)

    def stage_acceleration(self, q: np.ndarray, v: np.ndarray, command: np.ndarray,
                           body_wrench: np.ndarray | None = None, out: np.ndarray | None = None) -> np.ndarray:
        """v' (nv,) of :meth:`dynamics` alone (the same numbers), without the motor torques: an integrator's stage
        (Mbar and nbar in the pass's own buffers, overwritten at every call)."""
        compiled = self._compiled()
        return compiled.accelerations_into(q, v, command, body_wrench, out, *compiled.scratch, compiled.empty)

    def actuated_rate_into(self, q: np.ndarray, x: np.ndarray, arm: np.ndarray, thrust_command: np.ndarray,
                           thrusters: tuple[np.ndarray, np.ndarray], fin_wrench: np.ndarray | None,
                           wrench: np.ndarray, rates: np.ndarray, torques: bool) -> PlantDynamics | None:
        """An actuated plant's rate at (q, x = [v; f; ...]): [v'; f'] into ``rates`` (the fins' part left), the
        actuators' wrench B f (+ ``fin_wrench``) into ``wrench`` (6,), in one compiled call with the thrusters'
        (B (6, n), tau (n,)) and their lag f' = (f_cmd - f) / tau
        (:meth:`~uvms.dynamics.plant.compiled.CompiledPass.actuated_rate_into`); the PlantDynamics with ``torques``,
        else None (an integrator's stage: Mbar and nbar in the pass's own buffers)."""
        compiled = self._compiled()
        extra = compiled.empty if fin_wrench is None else fin_wrench
        return compiled.actuated_rate_into(q, x, arm, thrust_command, *thrusters, extra, wrench, rates, torques)

    def actuated_stage(self, held: list[np.ndarray],
                       thrusters: tuple[np.ndarray, np.ndarray]) -> Callable[[float, np.ndarray, np.ndarray], tuple]:
        """(t, q, x) -> (v, [v'; f']) (a new array) of :meth:`actuated_rate_into` without fins or torques, the same
        numbers, the commands read from ``held`` = [u (n_arm,), sat(f_cmd) (n,) [N]] (the caller points it at each
        step's commands) and the thrusters' (B, tau) bound once: an integrator's stage
        (:meth:`~uvms.dynamics.plant.compiled.CompiledPass.actuated_stage`)."""
        return self._compiled().actuated_stage(held, *thrusters)

    def _mass_and_bias(self, q: np.ndarray, v: np.ndarray,
                       body_wrench: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Mbar (nv, nv) and nbar (nv,) at (q, v): Mbar v' + nbar = [0; tau_m] (nbar = h - sum J^T f).

        Pinocchio gives M (crba), h (rnea, gravity included), its world Jacobian data.J (one array), the joints'
        placements and bias accelerations (views of its data: :class:`~uvms.dynamics.plant.data_views.JointArrays`);
        the links' LOCAL Jacobians J_l (``getFrameJacobian``'s numbers) and wrenches f_l (their frames) are formed
        and summed by virtual work in one compiled pass (:func:`uvms.numerics._kernels.hydro.plant_terms_into`):
        Mbar = M + sum_l J_l^T M_A,l J_l, nbar = h - sum_l J_l^T f_l - J_base^T body_wrench (the numbers of rnea
        with the wrenches as external forces, to rounding; J_base formed as ``getFrameJacobian`` forms it).
        """
        return self._compiled().terms(q, v, body_wrench)

    def _compiled(self) -> CompiledPass:
        """The plant's compiled pass (:class:`~uvms.dynamics.plant.compiled.CompiledPass`), made at the first
        evaluation (numba loads there)."""
        if self._pass is None:
            self._pass = CompiledPass(self.model, self.data, self._dynamics_data, self._joint_arrays, self._stacked,
                                      self._flags, self._current, self.nb, self.model.frames[self._base_frame],
                                      self.motor_time_constant)
        return self._pass

    def acceleration(self, q: np.ndarray, v: np.ndarray, command: np.ndarray) -> np.ndarray:
        """v' (nv,) at (q, v) under the joint-velocity command u (n_arm,)."""
        return self.evaluate(q, v, command).acceleration

    def derivative(self, state: tuple[np.ndarray, np.ndarray], command: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Time derivative of the state (q, v): (v (nv,) as a tangent vector at q, v' (nv,))."""
        q, v = state
        return v, self.acceleration(q, v, command)

    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        """Mbar (nv, nv): rigid mass matrix plus the links' added mass when ``added_mass`` is on."""
        return augmented_mass_matrix(self.model, self.data, self.links if self.added_mass else [], q)

    def generalized_jacobian(self, q: np.ndarray, frame: str | None = None) -> np.ndarray:
        """The GJM (6, n_arm) this plant conserves momentum with: added-mass-augmented when ``added_mass``."""
        state = Configuration(self.robot, q)
        split = mass_matrix_split(self.mass_matrix(state.q), self.nb)
        return generalized_jacobian_from_parts(state.jacobian(self.robot.frame_id(frame)), *split, self.nb)
