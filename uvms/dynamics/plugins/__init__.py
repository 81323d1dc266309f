"""The readers of simulator plugin blocks, registered by simulator (``readers``): Gazebo Sim (``gz_sim``) and
HippoCampus (``hippo``) here; uuv_simulator's forms, which its YAML documents share, with their concern
(:mod:`uvms.dynamics.thrusters.sources`, :mod:`uvms.dynamics.hydro.uuv`)."""
