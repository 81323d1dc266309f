"""The free-floating plant: the equations of motion of a UVMS in a fluid at Pinocchio's speed (``plant``), the added
mass of its hydrodynamic links (``added_mass``), the plant as a system of the one loop (``system``) and the vehicle
actuated by its thrusters and fins (``actuated``)."""
