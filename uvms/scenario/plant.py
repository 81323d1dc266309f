"""A scenario's dynamic ``[plant]`` (type rigid or hydrodynamic): the plant, and the keys only it uses."""

from __future__ import annotations

import numpy as np

from ..dynamics.hydro.hydrodynamics import HydroParameters, hydrodynamics_of
from ..dynamics.plant.plant import Plant
from ..errors import ScenarioError, UVMSError
from ..robot.robot import Robot
from .spec import PlantSpec


def make_plant(robot: Robot, section: PlantSpec) -> Plant:
    """The free-floating plant of a checked [plant] section (type rigid or hydrodynamic): the one place a scenario's
    plant is made (its values are checked where the file is read: :func:`uvms.scenario.spec.dynamics.check_plant`).

    Its hydrodynamics are plant.hydrodynamics (a YAML file in the scenario's folder, e.g. what ``uvms identify``
    wrote, checked against the model's links) when given, else the model's own.

    Raises:
        ScenarioError: a fixed base; plant.hydrodynamics not a hydrodynamics YAML of this model (the loader's
            message); a hydrodynamic plant of a model without hydrodynamic parameters.
    """
    if robot.base_type == "fixed":
        raise ScenarioError(f"plant.type = {section.type!r} needs a floating or planar vehicle; "
                            f"{robot.name} has a fixed base (set model.base or use plant.type = 'kinematic')")
    tau = float(section.motor_time_constant)
    if section.type == "rigid":
        return Plant(robot, HydroParameters(source="rigid plant (no fluid)"), gravity=False, motor_time_constant=tau,
                     added_mass=False, damping=False)
    try:
        hydro = hydrodynamics_of(robot, section.hydrodynamics) if section.hydrodynamics else None
    except UVMSError as exc:
        raise ScenarioError(f"plant.hydrodynamics: {' '.join(str(exc).split())}") from None
    plant = Plant(robot, hydro, gravity=section.gravity, motor_time_constant=tau,
                  current=np.array(section.current, dtype=float) if section.current else None,
                  added_mass=section.added_mass is not False, damping=section.damping is not False)
    if not plant.links:
        raise ScenarioError(f"plant.type = 'hydrodynamic' needs hydrodynamic parameters, and {robot.source} has none; "
                            f"add a uuv_simulator block or hydrodynamics.yaml (see uvms.dynamics.hydro.hydrodynamics), "
                            f"or use plant.type = 'rigid'")
    return plant
