"""Trajectories: time laws, Cartesian paths and pose trajectories, joint-space interpolation.

- ``laws``: s(t) with two derivatives (trapezoid, cubic, quintic).
- ``cartesian``: paths (circle, line) and pose trajectories (constant orientation, SE(3) interpolation).
- ``recent``: a trajectory that returns its last samples again (integrator stages share times).
- ``table``: a trajectory evaluated once at every time of a fixed-step run.
- ``settings``: a motion described by numbers (a scenario's ``[trajectory]``), built from the start pose.
- ``joint``: joint-space interpolation through via points (cubic, quintic), ``jtraj`` and ``ctraj``.
"""

from .cartesian import (
                        CirclePath,
                        LinePath,
                        PathSample,
                        PathSamples,
                        PathTrajectory,
                        PointPath,
                        PoseSample,
                        PoseSamples,
                        SE3Trajectory,
                        hold,
)
from .joint import CartesianSamples, JointSamples, ViaPointTrajectory, ctraj, jtraj
from .laws import LawSample, PolynomialLaw, TimeLaw, TrapezoidLaw, check_positive
from .ramps import VelocityRamps
from .recent import RecentSamples
from .settings import TrajectorySettings
from .table import TrajectoryTable

__all__ = [
    "CartesianSamples",
    "CirclePath",
    "JointSamples",
    "LawSample",
    "LinePath",
    "PathSample",
    "PathSamples",
    "PathTrajectory",
    "PolynomialLaw",
    "PoseSample",
    "PoseSamples",
    "PointPath",
    "RecentSamples",
    "SE3Trajectory",
    "TimeLaw",
    "TrajectorySettings",
    "TrajectoryTable",
    "TrapezoidLaw",
    "VelocityRamps",
    "ViaPointTrajectory",
    "check_positive",
    "ctraj",
    "hold",
    "jtraj",
]
