"""Configuration: one configuration q of a robot, with its own Pinocchio data and its kinematics computed once.

Every task, inequality objective and solver reads poses and Jacobians from a :class:`Configuration`, so a
solver step with several tasks runs Pinocchio's kinematics a single time. A configuration owns its
``pinocchio.Data``: two configurations never share state (building one never changes another's pose).

Each quantity is computed at most once per q, when first asked for (:class:`~uvms.robot.state.KinematicState`):
the joint placements and Jacobians (one ``computeJointJacobians``), each frame's placement (one
``updateFramePlacement``) and world-aligned Jacobian, and the momentum rows the vehicle
conserves (by default the rigid centroidal map; a controller may pass those of the added-mass-augmented
inertia or of a vehicle held still, :mod:`uvms.robot.kinematics`), from which the generalized Jacobian of
every task follows by the one formula. :meth:`Configuration.update` and :meth:`Configuration.integrate`
move it to another q and forget what was computed.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator

import numpy as np
import pinocchio as pin

from . import kinematics
from .robot import Robot, check_robot
from .state import KinematicState

#: Momentum rows of a configuration: q (nq,) -> (A_b (r, n_vehicle), A_m (r, n_arm)).
MomentumRows = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]


class Configuration(KinematicState):
    """A configuration q (nq,) of ``robot`` and what Pinocchio computes at it, in data of its own.

    Library code that loops over configurations keeps one Configuration and :meth:`update` s it (one
    ``pinocchio.Data``, no allocation per q).

    Args:
        robot: the model.
        q: configuration (nq,); checked unless ``check=False`` (hot loops on configurations produced by
            ``pin.integrate``).
        check: validate q (shape, finite, unit quaternion).
        momentum: q -> (A_b, A_m), the conserved momentum rows; None: the rigid centroidal map.

    Attributes:
        robot: the model; model: its ``pinocchio.Model``; data: this configuration's ``pinocchio.Data``; q: the
            configuration (nq,).
    """

    def __init__(self, robot: Robot, q: np.ndarray, *, check: bool = True,
                 momentum: MomentumRows | None = None) -> None:
        self.robot = check_robot(robot, type(self).__name__)
        super().__init__(robot.model)
        self._momentum = momentum
        self.update(q, check=check)

    def update(self, q: np.ndarray, *, check: bool = True) -> None:
        """Move to the configuration q (nq,); what was computed at the previous one is forgotten."""
        super().update(self.robot.check_configuration(q) if check else q)
        self._centroidal: tuple[np.ndarray, np.ndarray] | None = None

    def integrate(self, v: np.ndarray, dt: float) -> None:
        """Move along the velocity v (nv,) for dt [s]: q <- pin.integrate(q, v dt) (on the manifold)."""
        step = v * dt if v.__class__ is np.ndarray and v.dtype == np.float64 else np.asarray(v, dtype=float) * dt
        self.update(pin.integrate(self.model, self.q, step), check=False)

    def centroidal_split(self) -> tuple[np.ndarray, np.ndarray]:
        """Conserved momentum rows: A_b (k, n_vehicle), A_m (k, n_arm) (the centroidal map unless chosen).

        Raises:
            ModelCheckError: a fixed base: the model has no vehicle whose momentum is conserved.
        """
        if self._centroidal is None:
            robot = self.robot
            self._centroidal = (self._momentum(self.q) if self._momentum is not None
                                else self.centroidal_rows(robot.base_type, robot.n_vehicle))
        return self._centroidal

    def generalized(self, jacobian: np.ndarray) -> np.ndarray:
        """Generalized version (k, n_arm) of a task Jacobian (k, nv): the vehicle follows momentum.

        Raises:
            ModelCheckError: a fixed base (no vehicle), or a singular vehicle block of the momentum rows.
        """
        a_base, a_arm = self.centroidal_split()
        return kinematics.generalized_jacobian_from_parts(jacobian, a_base, a_arm, self.robot.n_vehicle)


def configurations(robot: Robot, qs: Iterable[np.ndarray], *, check: bool = True) -> Iterator[Configuration]:
    """One Configuration moved to each configuration of ``qs`` (N, nq) in turn: the loop over a run's rows (one
    ``pinocchio.Data`` for the whole series). Read what you need from each before taking the next.

    Raises:
        ConfigurationError: a row that is not a configuration of ``robot`` (when ``check``).
    """
    state = None
    for q in qs:
        if state is None:
            state = Configuration(robot, q, check=check)
        else:
            state.update(q, check=check)
        yield state
