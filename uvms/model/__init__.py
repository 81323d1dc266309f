"""The model layer: xacro/URDF in, a checked Pinocchio model out.

``loader`` (``load``: expand, check, choose the base, build), ``checks`` (URDF checks before Pinocchio),
``packages`` (the ROS package index of ``$(find)`` and ``package://``, without ROS),
``resources`` (shipped models, example-robot-data, ``package://``, bounded reading of files), ``includes``
(a xacro's static includes), ``sandbox`` (untrusted xacro in a kernel-confined child process), ``base_rule``
(which root is the vehicle), ``compose`` (``mount_arm``), ``point_masses`` (links with a mass and no inertia),
``joint_classes`` (arm joints, mimics, and the propellers, sensors and zero-range joints uvms freezes), ``meshes``
(mesh URIs resolved, mesh files refused by rule), ``collision`` (the ``<collision>`` shapes and the pairs checked),
``distances`` (signed distances of pairs and their Jacobian).
"""

from .base_rule import ADDED_BASE_JOINT, BASE_CHOICES
from .compose import mount_arm
from .loader import load, read_model_text
from .packages import package_index
from .resources import example_robot_urdf, shipped_models

__all__ = ["ADDED_BASE_JOINT", "BASE_CHOICES", "example_robot_urdf", "load", "mount_arm", "package_index",
           "read_model_text", "shipped_models"]
