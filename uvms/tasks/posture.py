"""Posture task: arm joints toward reference values."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ..robot.configuration import Configuration
from ..robot.robot import Robot
from .task import Task


class PostureTask(Task):
    """Drive the arm joints to a reference configuration (n_arm rows).

    Args:
        robot: the model.
        reference: reference configuration q (nq,); its vehicle part is ignored.
    """

    def __init__(self, robot: Robot, reference: np.ndarray) -> None:
        self.robot = robot
        self.reference = robot.check_configuration(reference)
        self.dim = robot.n_arm
        self._jacobian = np.hstack([np.zeros((robot.n_arm, robot.n_vehicle)), np.eye(robot.n_arm)])

    def error(self, state: Configuration) -> np.ndarray:
        return pin.difference(self.robot.model, state.q, self.reference)[self.robot.n_vehicle:]

    def jacobian(self, state: Configuration) -> np.ndarray:  # noqa: ARG002 - constant
        return self._jacobian
