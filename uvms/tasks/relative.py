"""Relative task: the distance between two frames (e.g. the claws of a dual-arm system)."""

from __future__ import annotations

import numpy as np

from ..errors import UVMSError
from ..robot.configuration import Configuration
from ..robot.robot import Robot
from .task import Task


class DistanceTask(Task):
    """Keep or drive the distance ``|p_b - p_a|`` between two frame origins to ``distance`` (1 row).

    Error ``d* - |p_b - p_a|``; Jacobian u^T (J_b - J_a) on the linear rows, with u the unit vector from a to b.
    The task is singular when the frames coincide; targets are then meaningless, so it is refused.

    Args:
        robot: the model.
        frame_a, frame_b: frame names.
        distance: target distance d* [m] >= 0.
    """

    dim = 1

    def __init__(self, robot: Robot, frame_a: str, frame_b: str, distance: float = 0.0) -> None:
        if frame_a == frame_b:
            raise UVMSError(f"a distance task needs two different frames, got {frame_a!r} twice")
        self.robot = robot
        self.frames = (frame_a, frame_b)
        self.frame_ids = (robot.frame_id(frame_a), robot.frame_id(frame_b))
        self.rate = 0.0
        self.set_target(distance)

    def set_target(self, distance: float, rate: float = 0.0) -> None:
        """Target distance d* [m] and its rate d*' [m/s] (feedforward)."""
        distance, rate = float(distance), float(rate)
        if not (np.isfinite(distance) and distance >= 0 and np.isfinite(rate)):
            raise UVMSError(f"a target distance must be finite and >= 0 with a finite rate, got {distance!r}, {rate!r}")
        self.distance, self.rate = distance, rate

    def _offset(self, state: Configuration) -> np.ndarray:
        a, b = self.frame_ids
        return state.pose(b).translation - state.pose(a).translation  # (3,) world

    def current(self, state: Configuration) -> float:
        """Current distance [m]."""
        return float(np.linalg.norm(self._offset(state)))

    def error(self, state: Configuration) -> np.ndarray:
        return np.array([self.distance - self.current(state)])

    def jacobian(self, state: Configuration) -> np.ndarray:
        offset = self._offset(state)
        length = np.linalg.norm(offset)
        if length < 1e-9:
            raise UVMSError(f"frames {self.frames[0]!r} and {self.frames[1]!r} "
                            "coincide: their distance has no gradient")
        a, b = self.frame_ids
        return ((offset / length) @ (state.jacobian(b)[:3] - state.jacobian(a)[:3]))[None, :]  # (1, nv)

    def feedforward(self, state: Configuration) -> np.ndarray:  # noqa: ARG002
        return np.array([self.rate])
