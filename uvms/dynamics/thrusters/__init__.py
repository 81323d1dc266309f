"""The vehicle's actuators: thrusters (``thrusters``, read by ``sources`` from uuv_simulator's plugin and the
thrusters YAML), fins and their lift and drag (``fins``, ``lift_drag``), and the allocation of a body wrench to them
(``allocation``, ``fin_allocation``)."""
