"""Every joint's placement and spatial motion of one ``pinocchio.Data`` as two arrays that compiled code reads.

The plant's compiled pass (:func:`uvms.numerics._kernels.hydro.plant_terms_into`) needs the links' joints'
placements ``data.oMi`` and bias accelerations ``data.a`` at every evaluation. Read through Pinocchio's getters they
cost a Python object per joint (about 5 us an evaluation on the BlueROV2 + Alpha 5, as much as the pass itself).
Pinocchio keeps them as contiguous arrays of doubles (a ``std::vector`` of SE3, each its rotation column-major then
its translation, 12 doubles; of Motion, each linear then angular, 6 doubles), and its getters hand out views of
that memory; :class:`JointArrays` checks that layout once against the getters' own addresses and views the whole
vector as one array. The numbers are Pinocchio's, not copies of them: nothing to keep in step.
"""

from __future__ import annotations

import ctypes

import numpy as np
import pinocchio as pin

#: Doubles per joint: a placement (rotation column-major (9), translation (3)) and a motion (linear (3), angular (3)).
PLACEMENT_SIZE, MOTION_SIZE = 12, 6
DOUBLE = np.dtype(float).itemsize


class JointArrays:
    """``data.oMi`` as placements (njoints, 12) and ``data.a`` as motions (njoints, 6) of one pin.Data.

    Row j of placements is joint j's oMi, its rotation R column-major then its translation p
    (R[i, k] = row[i + 3 k], p[i] = row[9 + i]); row j of motions its data.a, [linear; angular].

    Where Pinocchio stores them in that layout (checked here on the getters' addresses) the arrays are read-only
    views of the Data's memory: :meth:`read` returns them as they are, and they show what the last algorithm wrote.
    Otherwise they are buffers this object owns, which :meth:`read` fills from the getters (the same numbers).

    Args:
        data: the Data; it must outlive this object (the plant keeps both); its vectors are never resized after
            ``createData``.
        view: False: the owned buffers even where a view would do (what a test of both ways asks).

    Attributes:
        viewed: whether the arrays are views of the Data.
    """

    def __init__(self, data: pin.Data, *, view: bool = True) -> None:
        self._data = data
        count = len(data.oMi)
        placements, motions = (_viewed(data), _motion_view(data)) if view else (None, None)
        self.viewed = placements is not None and motions is not None
        if self.viewed:
            placements.flags.writeable = False
            motions.flags.writeable = False
            self._arrays = placements, motions
        else:
            self._arrays = np.empty((count, PLACEMENT_SIZE)), np.empty((count, MOTION_SIZE))

    def __reduce__(self) -> tuple:
        """A copy (pickle, deepcopy) views its own copy of the Data: views are never carried as copies of numbers."""
        return _joint_arrays, (self._data, self.viewed)

    def read(self) -> tuple[np.ndarray, np.ndarray]:
        """(placements (njoints, 12), motions (njoints, 6)) as the Data holds them now (views: no copy)."""
        if self.viewed:
            return self._arrays
        placements, motions = self._arrays
        for joint, (placement, motion) in enumerate(zip(self._data.oMi.tolist(), self._data.a.tolist())):
            placements[joint, :9] = placement.rotation.ravel(order="F")
            placements[joint, 9:] = placement.translation
            motions[joint] = motion.vector
        return self._arrays


def _joint_arrays(data: pin.Data, view: bool) -> JointArrays:
    """JointArrays(data, view=view) (what a copy is made by)."""
    return JointArrays(data, view=view)


#: Where each part of an item sits in its run of doubles: (getter, offset [doubles], numpy strides [bytes]).
PLACEMENT_PARTS = (("rotation", 0, (DOUBLE, 3 * DOUBLE)), ("translation", 9, (DOUBLE,)))  # column-major R, then p
MOTION_PARTS = (("linear", 0, (DOUBLE,)), ("angular", 3, (DOUBLE,)))


def _viewed(data: pin.Data) -> np.ndarray | None:
    """data.oMi as one (njoints, 12) view, or None where Pinocchio's layout is not the one assumed."""
    return _contiguous(data.oMi, PLACEMENT_PARTS, PLACEMENT_SIZE, data)


def _motion_view(data: pin.Data) -> np.ndarray | None:
    """data.a as one (njoints, 6) view, or None where Pinocchio's layout is not the one assumed."""
    return _contiguous(data.a, MOTION_PARTS, MOTION_SIZE, data)


def _contiguous(items, parts: tuple[tuple[str, int, tuple[int, ...]], ...], size: int,
                owner: pin.Data) -> np.ndarray | None:
    """The items of a Pinocchio vector as one (len(items), size) view of ``owner``'s memory when every item's parts
    are where ``parts`` says in one run of ``size`` doubles per item (checked on the getters' own addresses), else
    None."""
    start = getattr(items[0], parts[0][0]).ctypes.data
    for index in range(len(items)):
        item, origin = items[index], start + index * size * DOUBLE
        for name, offset, strides in parts:
            array = getattr(item, name)
            if array.ctypes.data != origin + offset * DOUBLE or array.strides != strides:
                return None
    return _array_at(start, (len(items), size), owner)


def _array_at(address: int, shape: tuple[int, int], owner: pin.Data) -> np.ndarray:
    """A C-ordered float array of ``shape`` over the memory at ``address``, which ``owner`` holds: the array keeps
    ``owner`` alive (its base's base holds it), so a view never outlives the Data it reads."""
    buffer = (ctypes.c_double * (shape[0] * shape[1])).from_address(address)
    buffer.owner = owner
    return np.frombuffer(buffer, dtype=float).reshape(shape)
