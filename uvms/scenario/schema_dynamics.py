"""The scenario schema's markers of number keys and its tables of the dynamic sections: ``[plant]``,
``[vehicle_control]`` and ``[excitation]`` (:data:`uvms.scenario.schema.SCHEMA` holds them with the others).

A table maps key -> (accepted types, default, allowed values or None), as every table of the schema.
"""

from __future__ import annotations

from ..control import gjm, vehicle

NUMBER = (int, float)
NUMBERS = "numbers"  # a list of numbers
#: [plant] types: the kinematic simulation (the vehicle follows momentum exactly, or is actuated), or the
#: free-floating dynamics of uvms.dynamics.plant.plant without (rigid) or with (hydrodynamic) the model's hydrodynamics.
PLANT_TYPES = ("kinematic", "rigid", "hydrodynamic")

PLANT: dict[str, tuple] = {
    "type": (str, "kinematic", PLANT_TYPES),
    "gjm": (str, "rigid", gjm.GJM_KINDS),
    "motor_time_constant": (NUMBER, 0.1, None),
    "motor_feedforward": (bool, False, None),
    "control_dt": (NUMBER, 0.0, None),
    "gravity": (bool, False, None),
    "added_mass": (bool, None, None),
    "damping": (bool, None, None),
    "current": (NUMBERS, [], None),
    "thrusters": (bool, False, None),  # the vehicle actuated by its thrusters ([vehicle_control])
    "hydrodynamics": (str, "", None),  # a hydrodynamics YAML in the scenario's folder; "": the model's own
}
VEHICLE_CONTROL: dict[str, tuple] = {  # plant.thrusters: the vehicle loop, the allocation and the arm's coordination
    "kp": ((int, float, list), None, None),  # None: from bandwidth, damping_ratio and the vehicle's inertia
    "ki": ((int, float, list), None, None),  # (uvms.control.vehicle.velocity_gains); given: used as it is
    "bandwidth": ((int, float, list), list(vehicle.DEFAULT_BANDWIDTH), None),  # [rad/s] per body axis
    "damping_ratio": ((int, float, list), list(vehicle.DEFAULT_DAMPING_RATIO), None),
    "pose_gains": ((int, float, list), 1.5, None),
    "max_speed": ((int, float, list), 0.5, None),
    "priorities": (list, [], None),
    "coordination": (bool, True, None),
    "arm_feedforward": (bool, True, None),
    "acceleration_feedforward": (bool, True, None),  # the reference's acceleration through the model's inertia
    "servo_compensation": (bool, True, None),  # the arm's servo lag inverted over the step
    "knows_current": (bool, False, None),
    "saturation_feedback": (bool, False, None),  # the allocation's shortfall bounds the vehicle's reference
}
#: plant.thrusters with excitation.wrench: the vehicle driven open loop by a multi-sine body wrench
#: (uvms.scenario.excitation), the log an identification reads; [vehicle_control] is not used.
EXCITATION: dict[str, tuple] = {
    "wrench": (NUMBERS, [], None),  # RMS [N, N m] per body axis x y z roll pitch yaw; []: no excitation
    "highest": (NUMBER, 0.5, None),  # [Hz] the highest sine; the lowest is highest / (6 components)
    "components": (int, 8, None),  # sines per axis
    "seed": (int, 0, None),  # 0: Schroeder's phases; else random phases of this seed
    "arm": (NUMBERS, [], None),  # amplitude [rad or m] per arm joint; []: the arm held
    "arm_period": (NUMBER, 20.0, None),  # [s] the first joint's period
}
