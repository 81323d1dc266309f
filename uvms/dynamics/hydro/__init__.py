"""Fossen hydrodynamics of the model's links: the parameters as uvms holds them (``parameters``), read from the model
file or a YAML document (``hydrodynamics``) in uuv_simulator's form (``uuv``, its shape models in ``shapes``), and
written back as that YAML (``writer``)."""
