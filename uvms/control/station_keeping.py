"""Station keeping with an end effector held at a point: the whole chain of an actuated UVMS, as one digital
controller of :func:`uvms.simulate_actuated.simulate_actuated`.

Per control step (period dt), from the measured (q, v):

1. vehicle pose loop: nu_ref = K_pose [R^T (p_d - p); log3(R^T R_d)] towards the station (vehicle.py);
2. kinematic controller: the end-effector point task v_task = K_ee (x_d - x) with the vehicle's part imposed,
   v_ref = [nu_ref; J_a^# (v_task - J_v nu_ref)] (a virtual-chain CLIK: the vehicle given, the arm solved);
3. arm command: without coordination qd_ref; with coordination the arm part solved again with the MEASURED
   vehicle velocity (coordination.py), so the arm takes up the vehicle's lag and drift;
4. vehicle velocity loop: model feedforward + PI -> body wrench -> thrust allocation -> thrust commands.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ..dynamics.actuated import ActuatedCommand
from ..dynamics.allocation import ThrustAllocator
from ..dynamics.plant import Plant
from ..dynamics.thrusters import Thrusters, allocation_matrix
from ..errors import SolverInputError
from ..robot import Robot
from ..solvers.inverses import damped_weighted_inverse
from .coordination import coordinated_arm_rates
from .vehicle import VehiclePoseController, VehicleVelocityController, gain_vector


class StationKeeping:
    """Hold the end effector at ``ee_target`` while the vehicle keeps station at ``vehicle_target``.

    Args:
        robot: a floating-base Robot (the controller's model of the kinematics).
        pose: the vehicle pose controller (with its velocity controller and allocation).
        vehicle_target: world_M_base wanted [m, rad]; ee_target: (3,) [m] world point for the end effector,
            or None: no end-effector task, the arm is held (zero joint rates).
        dt: control period [s] (the simulation step: the controller is called once per step).
        frame: end-effector frame (default: the first).
        ee_gain: K_ee [1/s] of the point task.
        coordination: re-solve the arm with the measured vehicle velocity (module docstring, step 3).
        arm_damping: DLS damping of the arm inverses (keeps the rates bounded near singularities).
        max_arm_rate: [rad/s] bound on every joint command (None: the model's velocity limits).

    Raises:
        SolverInputError: a non-floating base, bad gains, dt <= 0.
    """

    def __init__(self, robot: Robot, pose: VehiclePoseController, *, vehicle_target: pin.SE3,
                 ee_target: np.ndarray, dt: float, frame: str | None = None, ee_gain: float = 1.0,
                 coordination: bool = True, arm_damping: float = 0.01, max_arm_rate: float | None = None) -> None:
        if robot.base_type != "floating":
            raise SolverInputError(f"station keeping needs a floating base, {robot.name} is {robot.base_type}")
        if not (np.isfinite(dt) and dt > 0):
            raise SolverInputError(f"dt must be a control period > 0 s, got {dt!r}")
        self.robot, self.pose, self.dt = robot, pose, float(dt)
        self.velocity: VehicleVelocityController = pose.velocity
        self.vehicle_target = vehicle_target.copy()
        self.ee_target = None if ee_target is None else np.asarray(ee_target, dtype=float).reshape(3)
        self.frame = frame or robot.ee_frames[0]
        self.ee_gain = float(gain_vector(ee_gain, "ee_gain", 1)[0])
        self.coordination, self.arm_damping = bool(coordination), float(arm_damping)
        limits = robot.model.velocityLimit[robot.n_vehicle:]
        self.max_arm_rate = np.where(np.isfinite(limits) & (limits > 0), limits, np.inf) if max_arm_rate is None \
            else np.full(robot.n_arm, float(max_arm_rate))
        self._base_placement = self.velocity.model._base_placement

    def base_pose(self, q: np.ndarray) -> pin.SE3:
        """world_M_base of the vehicle's base frame (its link frame, not only the joint)."""
        return self.robot.base_pose(q) * self._base_placement

    def reference(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(nu_ref (6,) base frame, v_ref (nv,) in the axes of v, J (3, nv) of the point task) at q."""
        robot, nb = self.robot, self.robot.n_vehicle
        nu_ref = self.pose.reference(self.base_pose(q), self.vehicle_target)
        vehicle_ref = self._base_placement.act(pin.Motion(nu_ref)).vector  # base frame -> vehicle joint axes
        jacobian = robot.jacobian(q, self.frame)[:3]  # (3, nv) world-aligned
        if self.ee_target is None:  # the arm held still
            return nu_ref, np.concatenate([vehicle_ref, np.zeros(robot.n_arm)]), jacobian
        task = self.ee_gain * (self.ee_target - robot.fk(q, self.frame).translation)
        inverse, _, _ = damped_weighted_inverse(jacobian[:, nb:], None, self.arm_damping)
        arm_ref = inverse @ (task - jacobian[:, :nb] @ vehicle_ref)
        return nu_ref, np.concatenate([vehicle_ref, arm_ref]), jacobian

    def __call__(self, t: float, q: np.ndarray, v: np.ndarray, thrusts: np.ndarray) -> ActuatedCommand:
        """The arm and thrust commands for the step from (t, q, v); advances the velocity loop's integral."""
        nb = self.robot.n_vehicle
        nu_ref, v_ref, jacobian = self.reference(q)
        if self.coordination and self.ee_target is not None:
            arm = coordinated_arm_rates(jacobian, v_ref, v[:nb], nb, damping=self.arm_damping)
        else:
            arm = v_ref[nb:]
        arm = np.clip(arm, -self.max_arm_rate, self.max_arm_rate)
        arm_acceleration = (arm - v[nb:]) / self.velocity.model.motor_time_constant  # the servo the model knows
        control = self.velocity.control(q, v, nu_ref, self.dt, arm_acceleration=arm_acceleration)
        pose = self.base_pose(q)
        attitude_error = pin.log3(pose.rotation.T @ self.vehicle_target.rotation)  # [rad], body axes
        info = {"wrench_command": control.wrench, "achieved_wrench": control.allocation.achieved_wrench,
                "attainable": control.allocation.attainable, "velocity_integral": self.velocity.integral.copy(),
                "vehicle_position_error": float(np.linalg.norm(self.vehicle_target.translation - pose.translation)),
                "vehicle_attitude_error": float(np.linalg.norm(attitude_error)),
                "ee_position": self.robot.fk(q, self.frame).translation.copy()}
        if self.ee_target is not None:
            info["ee_point_error"] = float(np.linalg.norm(self.ee_target - info["ee_position"]))
        return ActuatedCommand(arm, control.allocation.thrusts, info)


def station_keeping(plant: Plant, thrusters: Thrusters, q0: np.ndarray, dt: float, *,
                    ee_target: np.ndarray | None = None, hold_arm: bool = False, coordination: bool = True,
                    knows_current: bool = False, kp: float | np.ndarray = (100.0, 100.0, 100.0, 10.0, 10.0, 10.0),
                    ki: float | np.ndarray = (150.0, 150.0, 150.0, 15.0, 15.0, 15.0),
                    pose_gains: float | np.ndarray = 1.5, max_speed: float | np.ndarray | None = 0.5,
                    priorities=None, arm_feedforward: bool = True, ee_gain: float = 1.0,
                    arm_damping: float = 0.01) -> StationKeeping:
    """The StationKeeping controller of ``plant`` holding the vehicle at its pose of q0 and the end effector at
    ``ee_target`` (default: where it is at q0; ``hold_arm``: no end-effector task, the arm held), with the
    allocation of ``thrusters``. The default gains hold the BlueROV2 + Alpha 5 in a 0.3 m/s current to 5 cm.

    Args:
        plant: the simulated plant; its robot and hydrodynamics are the controller's model, without the
            current unless ``knows_current``.
        thrusters: the vehicle's thrusters; q0: (nq,) the station; dt: control period [s].
        kp [N s/m, N m s/rad], ki [N/m, N m/rad]: velocity PI gains (6,) or numbers; pose_gains [1/s];
        max_speed: [m/s, rad/s] bound of the pose loop's reference; priorities: of the allocation
            (:class:`uvms.dynamics.allocation.ThrustAllocator`); arm_feedforward, ee_gain, arm_damping: as in
            :class:`uvms.control.vehicle.VehicleVelocityController` and :class:`StationKeeping`.
    """
    robot = plant.robot
    model = Plant(robot, plant.hydro if knows_current else plant.hydro.with_current(np.zeros(3)),
                  gravity=plant.gravity, motor_time_constant=plant.motor_time_constant,
                  added_mass=plant.added_mass, damping=plant.damping)
    allocator = ThrustAllocator(allocation_matrix(robot, thrusters), thrusters.lower, thrusters.upper,
                                priorities=priorities)
    velocity = VehicleVelocityController(model, allocator, kp, ki, arm_feedforward=arm_feedforward)
    pose = VehiclePoseController(velocity, pose_gains, max_speed)
    base = robot.base_pose(q0) * model._base_placement
    target = None if hold_arm else robot.fk(q0).translation if ee_target is None else ee_target
    return StationKeeping(robot, pose, vehicle_target=base, ee_target=target, dt=dt, coordination=coordination,
                          ee_gain=ee_gain, arm_damping=arm_damping)
