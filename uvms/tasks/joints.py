"""Joint task: named one-DOF joints (a claw, a wrist) toward target values."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..errors import UVMSError
from ..robot.configuration import Configuration
from ..robot.robot import Robot
from .task import Task


class JointTask(Task):
    """Drive named one-DOF joints to targets (one row per joint), e.g. to open or close a claw.

    Args:
        robot: the model.
        targets: joint name -> target value [rad or m] (inside the joint's limits).
    """

    def __init__(self, robot: Robot, targets: Mapping[str, float]) -> None:
        if not targets:
            raise UVMSError("a joint task needs at least one joint")
        self.robot = robot
        self.names = list(targets)
        infos = []
        for name in self.names:
            info = robot.joint(name)
            if info.nq != 1 or info.nv != 1:
                raise UVMSError(f"joint {name!r} has nq = {info.nq}: a joint task takes one-DOF joints only")
            infos.append(info)
        self.idx_q = np.array([info.idx_q for info in infos])
        self.idx_v = np.array([info.idx_v for info in infos])
        self.lower = np.array([info.lower[0] for info in infos])
        self.upper = np.array([info.upper[0] for info in infos])
        self.dim = len(self.names)
        self._jacobian = np.zeros((self.dim, robot.nv))
        self._jacobian[np.arange(self.dim), self.idx_v] = 1.0
        self.rates = np.zeros(self.dim)
        self.set_target(targets)

    def set_target(self, targets: Mapping[str, float], rates: Mapping[str, float] | None = None) -> None:
        """Targets [rad or m] (and their rates [/s]) for some or all of the task's joints."""
        unknown = sorted(set(targets) - set(self.names))
        if unknown:
            raise UVMSError(f"joint(s) {', '.join(unknown)} are not in this task; valid: {', '.join(self.names)}")
        values = getattr(self, "targets", np.zeros(self.dim)).copy()
        for name, value in targets.items():
            values[self.names.index(name)] = float(value)
        outside = ~np.isfinite(values) | (values < self.lower - 1e-12) | (values > self.upper + 1e-12)
        if outside.any():
            bad = [f"{self.names[i]} = {values[i]!r} not in [{self.lower[i]:g}, {self.upper[i]:g}]"
                   for i in np.flatnonzero(outside)]
            raise UVMSError(f"joint targets outside the limits: {'; '.join(bad)}")
        self.targets = values
        for name, rate in (rates or {}).items():
            self.rates[self.names.index(name)] = float(rate)

    def error(self, state: Configuration) -> np.ndarray:
        return self.targets - state.q[self.idx_q]

    def jacobian(self, state: Configuration) -> np.ndarray:  # noqa: ARG002 - constant
        return self._jacobian

    def feedforward(self, state: Configuration) -> np.ndarray:  # noqa: ARG002
        return self.rates.copy()
