"""A scenario's dynamic ``[plant]`` (type rigid or hydrodynamic): the plant, and the keys only it uses."""

from __future__ import annotations

import numpy as np

from ..dynamics.hydro.hydrodynamics import HydroParameters, hydrodynamics_of
from ..dynamics.plant.plant import Plant
from ..errors import ScenarioError, UVMSError
from ..robot.robot import Robot
from .spec import PlantSpec


def check_kinematic_plant(section: PlantSpec) -> None:
    """Reject [plant] keys that only a dynamic plant uses when plant.type = 'kinematic'."""
    unused = section.changed(("gjm", "motor_feedforward", "control_dt", "gravity",
                                                        "added_mass", "damping", "current", "thrusters",
                                                        "hydrodynamics"))
    if unused:
        raise ScenarioError(f"plant.{unused[0]} needs a dynamic plant: the kinematic one moves the vehicle by momentum "
                            f"conservation (solver.free_floating) or as commanded; set plant.type = 'rigid' or "
                            f"'hydrodynamic'")


def make_plant(robot: Robot, section: PlantSpec) -> Plant:
    """The free-floating plant of a [plant] section (type rigid or hydrodynamic)."""
    tau = float(section.motor_time_constant)
    if not tau > 0:
        raise ScenarioError(f"plant.motor_time_constant must be > 0 s (the joint servos' time constant), got {tau:g}")
    current = None
    if section.current:
        if len(section.current) != 3:
            raise ScenarioError(f"plant.current must have 3 numbers (world ENU [m/s]), got {len(section.current)}")
        current = np.array(section.current, dtype=float)
    if robot.base_type == "fixed":
        raise ScenarioError(f"plant.type = {section.type!r} needs a floating or planar vehicle; "
                            f"{robot.name} has a fixed base (set model.base or use plant.type = 'kinematic')")
    if section.type == "rigid":
        for key in ("added_mass", "damping"):
            if getattr(section, key):
                raise ScenarioError(f"plant.{key} = true needs plant.type = 'hydrodynamic'; a rigid plant has no fluid")
        if section.gravity or current is not None or section.hydrodynamics:
            raise ScenarioError("plant.gravity, current and hydrodynamics need plant.type = 'hydrodynamic' (buoyancy, "
                                "fluid); a rigid plant floats weightless in vacuum")
        return Plant(robot, HydroParameters(source="rigid plant (no fluid)"), gravity=False, motor_time_constant=tau,
                     added_mass=False, damping=False)
    added_mass = True if section.added_mass is None else section.added_mass
    damping = True if section.damping is None else section.damping
    plant = Plant(robot, scenario_hydrodynamics(robot, section), gravity=section.gravity, motor_time_constant=tau,
                  current=current, added_mass=added_mass, damping=damping)
    if not plant.links:
        raise ScenarioError(f"plant.type = 'hydrodynamic' needs hydrodynamic parameters, and {robot.source} has none; "
                            f"add a uuv_simulator block or hydrodynamics.yaml (see uvms.dynamics.hydro.hydrodynamics), "
                            f"or use plant.type = 'rigid'")
    return plant


def scenario_hydrodynamics(robot: Robot, section: PlantSpec) -> HydroParameters | None:
    """The hydrodynamics of plant.hydrodynamics (a YAML file in the scenario's folder, e.g. what ``uvms identify``
    wrote), checked against the model's links; None when not given (the model's own).

    Raises:
        ScenarioError: the file is not a hydrodynamics YAML of this model (the loader's message).
    """
    if not section.hydrodynamics:
        return None
    try:
        return hydrodynamics_of(robot, section.hydrodynamics)
    except UVMSError as exc:
        raise ScenarioError(f"plant.hydrodynamics: {' '.join(str(exc).split())}") from None
