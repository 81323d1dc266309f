"""The free-floating plant's settings: rigid-body dynamics in vacuum or in a fluid, the servos, the current.

One frozen object, checked where it is made, that :meth:`uvms.dynamics.plant.plant.Plant.from_settings` builds the
plant of a robot from (a scenario's ``[plant]`` section is made from it when the file is read: its keys of the same
names are these fields, its defaults these defaults).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

from ...errors import UVMSError

#: The plant's kinds: free-floating rigid-body dynamics in vacuum (no fluid), or with the model's hydrodynamics
#: (buoyancy, added mass, damping, current).
PLANT_KINDS = ("rigid", "hydrodynamic")
#: What only a plant in a fluid has.
FLUID = ("gravity", "added_mass", "damping", "current", "hydrodynamics")


@dataclass(frozen=True, kw_only=True)
class PlantSettings:
    """What the free-floating plant is made of (:class:`uvms.dynamics.plant.plant.Plant`).

    Attributes:
        type: one of :data:`PLANT_KINDS`.
        motor_time_constant: the joint servos' first-order time constant tau [s] (> 0).
        gravity: ``hydrodynamic``: weight and buoyancy (False: neutral buoyancy everywhere).
        added_mass: ``hydrodynamic``: the links' added mass and its Coriolis term; None: on.
        damping: ``hydrodynamic``: linear and quadratic drag; None: on.
        current: constant ocean current (3,) [m/s, world ENU]; (): the hydrodynamics' own.
        hydrodynamics: a hydrodynamics YAML used instead of the model's own; "": the model's.

    Raises:
        UVMSError: a kind not known, tau not > 0, a current not of 3 numbers, a fluid's setting on a rigid plant
            (each message begins with the field it is about).
    """

    type: str = "hydrodynamic"
    motor_time_constant: float = 0.1
    gravity: bool = False
    added_mass: bool | None = None
    damping: bool | None = None
    current: tuple[float, ...] = ()
    hydrodynamics: str = ""

    def __post_init__(self) -> None:
        if self.type not in PLANT_KINDS:
            raise UVMSError(f"type must be one of {', '.join(PLANT_KINDS)}, got {self.type!r}")
        tau = self.motor_time_constant
        if not (math.isfinite(tau) and tau > 0):
            raise UVMSError(f"motor_time_constant must be > 0 s (the joint servos' time constant), got {tau:g}")
        if self.current and len(self.current) != 3:
            raise UVMSError(f"current must have 3 numbers (world ENU [m/s]), got {len(self.current)}")
        if self.type == "rigid":
            for name in FLUID:
                if getattr(self, name):
                    raise UVMSError(f"{name} needs type = 'hydrodynamic' (buoyancy, fluid); a rigid plant has no "
                                    f"fluid: it floats weightless in vacuum")

    @classmethod
    def names(cls) -> tuple[str, ...]:
        """The settings' names, in their order."""
        return tuple(item.name for item in fields(cls))


__all__ = ["FLUID", "PLANT_KINDS", "PlantSettings"]
