"""Station keeping with an end effector held at a point: the whole chain of an actuated UVMS, as one digital
controller of an ``ActuatedPlant`` for :func:`uvms.sim.loop.simulate`.

Per control step (period dt), from the measured (q, v):

1. vehicle pose loop: nu_ref = K_pose [R^T (p_d - p); log3(R^T R_d)] towards the station (vehicle.py);
2. kinematic controller (:class:`StationKeeping`): the end-effector point task v_task = K_ee (x_d - x) with the
   vehicle's part imposed, v_ref = [nu_ref; J_a^# (v_task - J_v nu_ref)] (a virtual-chain CLIK: the vehicle
   given, the arm solved);
3. arm command: without coordination qd_ref; with coordination the arm part solved again with the MEASURED
   vehicle velocity, so the arm takes up the vehicle's lag and drift;
4. vehicle velocity loop: model feedforward + PI -> body wrench -> thrust allocation -> thrust commands.

Steps 3-4 are :class:`uvms.control.coordination.CoordinatedControl`, which takes any kinematic controller.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ..dynamics.allocation import ThrustAllocator
from ..dynamics.plant import Plant
from ..dynamics.thrusters import Thrusters, allocation_matrix
from ..errors import SolverInputError
from ..robot.robot import Robot
from .coordination import CoordinatedControl, arm_rates_for_task
from .vehicle import VehiclePoseController, VehicleVelocityController, gain_vector


class StationKeeping:
    """The kinematic reference of station keeping: the vehicle at ``vehicle_target``, the end effector at
    ``ee_target`` (module docstring, steps 1-2), a kinematic controller (t, q, None) -> (v_ref, info).

    Args:
        robot: a floating-base Robot.
        pose: the vehicle pose controller.
        vehicle_target: world_M_base wanted [m, rad]; ee_target: (3,) [m] world point for the end effector,
            or None: no end-effector task, the arm held (zero joint rates).
        frame: end-effector frame (default: the first).
        ee_gain: K_ee [1/s] of the point task.
        arm_damping: DLS damping of the arm inverse.
        base_placement: the base frame in the vehicle joint's frame (``Plant._base_placement``; None: identity).

    Raises:
        SolverInputError: a non-floating base, a bad gain.
    """

    def __init__(self, robot: Robot, pose: VehiclePoseController, *, vehicle_target: pin.SE3,
                 ee_target: np.ndarray | None, frame: str | None = None, ee_gain: float = 1.0,
                 arm_damping: float = 0.01, base_placement: pin.SE3 | None = None) -> None:
        if robot.base_type != "floating":
            raise SolverInputError(f"station keeping needs a floating base, {robot.name} is {robot.base_type}")
        self.robot, self.pose = robot, pose
        self.vehicle_target = vehicle_target.copy()
        self.ee_target = None if ee_target is None else np.asarray(ee_target, dtype=float).reshape(3)
        self.frame = frame or robot.ee_frames[0]
        self.ee_gain = float(gain_vector(ee_gain, "ee_gain", 1)[0])
        self.arm_damping = float(arm_damping)
        self.base_placement = pin.SE3.Identity() if base_placement is None else base_placement.copy()

    def base_pose(self, q: np.ndarray) -> pin.SE3:
        """world_M_base of the vehicle's base frame (its link frame, not only the joint)."""
        return self.robot.base_pose(q) * self.base_placement

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        """J (3, nv) of the end-effector point, world-aligned (the task coordination keeps)."""
        return self.robot.jacobian(q, self.frame)[:3]

    def __call__(self, t: float, q: np.ndarray, v: np.ndarray | None = None) -> tuple[np.ndarray, dict]:
        """v_ref (nv,) (vehicle part in the vehicle joint's axes) and {"nu_ref": (6,) base frame} at q."""
        robot, nb = self.robot, self.robot.n_vehicle
        nu_ref = self.pose.reference(self.base_pose(q), self.vehicle_target)
        vehicle_ref = self.base_placement.act(pin.Motion(nu_ref)).vector  # base frame -> vehicle joint axes
        if self.ee_target is None:  # the arm held still
            return np.concatenate([vehicle_ref, np.zeros(robot.n_arm)]), {"nu_ref": nu_ref}
        jacobian = self.jacobian(q)
        task = self.ee_gain * (self.ee_target - robot.fk(q, self.frame).translation)
        arm = arm_rates_for_task(jacobian, task, vehicle_ref, nb, damping=self.arm_damping)
        return np.concatenate([vehicle_ref, arm]), {"nu_ref": nu_ref}

    def errors(self, q: np.ndarray) -> dict:
        """The series of a row: vehicle position [m] and attitude [rad] errors, end-effector position and error."""
        pose = self.base_pose(q)
        ee = self.robot.fk(q, self.frame).translation.copy()
        attitude_error = pin.log3(pose.rotation.T @ self.vehicle_target.rotation)  # body axes [rad]
        row = {"vehicle_position_error": float(np.linalg.norm(self.vehicle_target.translation - pose.translation)),
               "vehicle_attitude_error": float(np.linalg.norm(attitude_error)), "ee_position": ee}
        if self.ee_target is not None:
            row["ee_point_error"] = float(np.linalg.norm(self.ee_target - ee))
        return row


def station_keeping(plant: Plant, thrusters: Thrusters, q0: np.ndarray, dt: float, *,
                    ee_target: np.ndarray | None = None, hold_arm: bool = False, coordination: bool = True,
                    knows_current: bool = False, kp: float | np.ndarray = (100.0, 100.0, 100.0, 10.0, 10.0, 10.0),
                    ki: float | np.ndarray = (150.0, 150.0, 150.0, 15.0, 15.0, 15.0),
                    pose_gains: float | np.ndarray = 1.5, max_speed: float | np.ndarray | None = 0.5,
                    priorities=None, arm_feedforward: bool = True, ee_gain: float = 1.0,
                    arm_damping: float = 0.01, frame: str | None = None) -> CoordinatedControl:
    """The controller of ``plant`` holding the vehicle at its pose of q0 and the end effector at ``ee_target``
    (default: where it is at q0; ``hold_arm``: no end-effector task, the arm held), with the allocation of
    ``thrusters``. The default gains hold the BlueROV2 + Alpha 5 in a 0.3 m/s current to 5 cm.

    Args:
        plant: the simulated plant; its robot and hydrodynamics are the controller's model, without the
            current unless ``knows_current``.
        thrusters: the vehicle's thrusters; q0: (nq,) the station; dt: control period [s].
        kp [N s/m, N m s/rad], ki [N/m, N m/rad]: velocity PI gains (6,) or numbers; pose_gains [1/s];
        max_speed: [m/s, rad/s] bound of the pose loop's reference; priorities: of the allocation
            (:class:`uvms.dynamics.allocation.ThrustAllocator`); arm_feedforward, ee_gain, arm_damping: as in
            :class:`uvms.control.vehicle.VehicleVelocityController` and :class:`StationKeeping`.
        frame: the end-effector frame held (default: the model's first end effector).

    Returns:
        A CoordinatedControl whose ``kinematic`` is the StationKeeping reference.
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
    frame = frame or robot.ee_frames[0]
    target = None if hold_arm else robot.fk(q0, frame).translation if ee_target is None else ee_target
    reference = StationKeeping(robot, pose, vehicle_target=base, ee_target=target, frame=frame, ee_gain=ee_gain,
                               arm_damping=arm_damping, base_placement=model._base_placement)
    return CoordinatedControl(robot, velocity, reference, dt, task_jacobian=reference.jacobian,
                              coordination=coordination and target is not None, arm_damping=arm_damping,
                              monitor=reference.errors)
