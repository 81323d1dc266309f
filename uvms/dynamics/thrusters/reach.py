"""What a thruster layout can reach: the body-wrench directions of B (6, n) judged at a physical rank tolerance.

:data:`RANK_TOLERANCE` (relative to B's largest singular value), not numpy's rounding-level one: a direction a layout
gives only through rounding is not reachable, and the allocation (:mod:`.allocation`) works on B truncated to its
reachable directions. The directions left out are named by their largest component, in axis order; where several are
exactly unreachable their basis is the one of their span in axis order (:func:`axis_ordered`), not LAPACK's (which is
arbitrary there and changes between builds).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...robot.conventions import AXIS_NAMES

__all__ = ["RANK_TOLERANCE", "ROUNDING", "UnreachableDirection", "axis_ordered", "rank", "reachable_directions"]

#: A singular value of B below this fraction of the largest is a direction the thrusters cannot produce: a wrench of
#: 1e-6 N (or N m) per newton of thrust is far below any thruster's resolution, and far above rounding (1e-16).
RANK_TOLERANCE = 1e-6
#: A singular value below this fraction of the largest is rounding: the direction is exactly unreachable (a symmetric
#: fin cross's null pattern gives 4e-17), and no thrusters are named as fighting for it.
ROUNDING = 1e-12


@dataclass(frozen=True)
class UnreachableDirection:
    """A body-wrench direction the thrusters cannot produce (a singular direction of B below the rank tolerance).

    Attributes:
        wrench: (6,) unit vector in wrench space [fx, fy, fz, mx, my, mz] (N and N m mixed, as B's rows).
        axis: the name of its largest component (``uvms.robot.conventions.AXIS_NAMES``: x, y, z forces; roll, pitch,
            yaw moments).
        thrusters: indices of the thrusters that would have to fight each other to produce it (the large entries of
            the matching right singular vector); empty when no combination produces it at all.
        ratio: its singular value over the largest (0 when exactly unreachable).
    """

    wrench: np.ndarray
    axis: str
    thrusters: tuple[int, ...]
    ratio: float


def rank(matrix: np.ndarray) -> int:
    """The rank of ``matrix`` judged at :data:`RANK_TOLERANCE` of its largest singular value."""
    singular = np.linalg.svd(matrix, compute_uv=False)
    return int(np.sum(singular > RANK_TOLERANCE * singular[0])) if singular.size and singular[0] > 0 else 0


def reachable_directions(matrix: np.ndarray) -> tuple[np.ndarray, tuple[UnreachableDirection, ...]]:
    """B (6, n) truncated to the singular directions above :data:`RANK_TOLERANCE`, and the directions left out."""
    u, singular, vt = np.linalg.svd(matrix)  # u (6, 6), vt (n, n); singular (min(6, n),), descending
    largest = singular[0] if singular.size else 0.0
    kept = int(np.sum(singular > RANK_TOLERANCE * largest)) if largest > 0 else 0
    # nothing dropped: B itself (the same numbers as B, not U S V^T's rounding of them)
    reachable = matrix if kept == min(matrix.shape) else (u[:, :kept] * singular[:kept]) @ vt[:kept]
    exact = kept + int(np.sum(singular[kept:] > ROUNDING * largest))  # the directions after it: exactly unreachable
    u[:, exact:] = axis_ordered(u[:, exact:])  # (LAPACK's basis of a null space of dimension > 1 is arbitrary)
    unreachable = []
    for index in range(kept, 6):
        direction = u[:, index] * np.sign(u[np.argmax(np.abs(u[:, index])), index])  # its largest entry positive
        ratio = float(singular[index] / largest) if index < singular.size and largest > 0 else 0.0
        ratio = ratio if ratio > ROUNDING else 0.0  # a rounding-level value: exactly unreachable, no pair to name
        fighting = np.abs(vt[index]) if index < singular.size and ratio > 0 else np.zeros(matrix.shape[1])
        unreachable.append(UnreachableDirection(direction, AXIS_NAMES[int(np.argmax(np.abs(direction)))],
                                                tuple(int(i) for i in np.flatnonzero(fighting > 0.3)), ratio))
    return reachable, tuple(sorted(unreachable, key=lambda item: AXIS_NAMES.index(item.axis)))  # in axis order


def axis_ordered(null: np.ndarray) -> np.ndarray:
    """An orthonormal basis (6, k) of the span of ``null`` (6, k) whatever basis it is given in: its projector's
    columns P e_i in axis order (x, y, z forces, roll, pitch, yaw moments), each without what the ones before hold
    (Gram-Schmidt, twice), those of a norm above 1e-8 kept."""
    projector = null @ null.T
    chosen: list[np.ndarray] = []
    for axis in range(6):
        vector = projector[:, axis]
        for _ in range(2):  # twice: orthogonal to rounding
            vector = vector - sum((basis @ vector) * basis for basis in chosen)
        norm = float(np.linalg.norm(vector))
        if norm > 1e-8 and len(chosen) < null.shape[1]:
            chosen.append(vector / norm)
    return np.column_stack(chosen) if chosen and len(chosen) == null.shape[1] else null
