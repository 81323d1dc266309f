"""A square solve inside a compiled kernel with the LAPACK the Python code it replaces calls, bit for bit: numpy's
(``numpy.linalg.solve``'s numbers: a plant's vehicle block) or SciPy's (``scipy.linalg.lapack.dgesv``'s: an RK4 stage's
tangent, :func:`uvms.numerics.integrate.rk4_step`).

numba's ``np.linalg.solve`` calls SciPy's LAPACK, another OpenBLAS build than numpy's, and its numbers differ from
numpy's in the last bits (moved far enough by a long closed-loop run to change amundsen2018's metrics beyond 1e-9). The
kernels here call the ``dgesv`` each Python path called: numpy's address is read from numpy's linear-algebra extension
at import (the dynamic linker resolves it in the LAPACK numpy loaded), SciPy's from its ``cython_lapack``, and each is
given to LLVM under a name of its own (:data:`NUMPY_SYMBOL`, :data:`SCIPY_SYMBOL`), which the compiled code calls: the
on-disk cache keeps the names, not addresses, so a cached kernel links to this process's libraries (and a name is never
changed without clearing the cache: a kernel cached with a name no longer registered would call nothing).

Where numpy's LAPACK does not export a ``dgesv`` by a known name (a numpy built against Accelerate or MKL under other
names), SciPy's stands for it: the same equations, equal to rounding. Either LAPACK takes 32- or 64-bit integers: every
integer argument lives in a 64-bit slot, which a 32-bit LAPACK reads as its low half (the platforms numba runs on are
little-endian), and a non-zero ``info`` is non-zero in either.

The module imports numba and registers the names, so it is loaded where a kernel that solves is first used.
"""

from __future__ import annotations

import ctypes
import sys

import llvmlite.binding as llvm
import numpy as np
from numba import njit, types

from ...errors import UVMSError

__all__ = ["NUMPY_SYMBOL", "SCIPY_SYMBOL", "dgesv_into", "solve_into"]

#: The names the compiled kernels call numpy's and SciPy's dgesv by.
NUMPY_SYMBOL, SCIPY_SYMBOL = "uvms_numpy_dgesv", "uvms_scipy_dgesv"
#: dgesv's names in numpy's LAPACK builds: its wheels' scipy-openblas (64- or 32-bit integers), a plain LAPACK, and
#: macOS's Accelerate (numpy >= 2 on macOS 14).
NUMPY_NAMES = ("scipy_dgesv_64_", "scipy_dgesv_", "dgesv_64_", "dgesv_", "dgesv$NEWLAPACK$ILP64", "dgesv$NEWLAPACK")


def numpy_dgesv_address() -> int | None:
    """The address of the dgesv numpy's ``linalg.solve`` calls, or None when numpy's LAPACK exports none of
    :data:`NUMPY_NAMES`."""
    from numpy.linalg import _umath_linalg

    try:
        library = ctypes.CDLL(_umath_linalg.__file__)  # dlsym through it searches the libraries it was linked with
    except OSError:  # a platform whose extensions ctypes cannot open: SciPy's stands for it
        return None
    for name in NUMPY_NAMES:
        try:
            return ctypes.cast(getattr(library, name), ctypes.c_void_p).value
        except AttributeError:
            continue
    return None


def scipy_dgesv_address() -> int:
    """The address of SciPy's dgesv (``scipy.linalg.cython_lapack``, what numba's solve calls)."""
    from scipy.linalg import cython_lapack

    capsule = cython_lapack.__pyx_capi__["dgesv"]
    # prototypes of our own (setting restype on ctypes.pythonapi's shared functions would change them for everyone)
    get_name = ctypes.PYFUNCTYPE(ctypes.c_char_p, ctypes.py_object)(("PyCapsule_GetName", ctypes.pythonapi))
    get_pointer = ctypes.PYFUNCTYPE(ctypes.c_void_p, ctypes.py_object, ctypes.c_char_p)(("PyCapsule_GetPointer",
                                                                                        ctypes.pythonapi))
    return get_pointer(capsule, get_name(capsule))


def _register() -> None:
    if sys.byteorder != "little":  # pragma: no cover - numba's platforms are little-endian
        raise UVMSError("the compiled solve needs a little-endian machine (its LAPACK integers share 64-bit slots)")
    scipy_address, numpy_address = scipy_dgesv_address(), numpy_dgesv_address()
    llvm.add_symbol(SCIPY_SYMBOL, scipy_address)
    llvm.add_symbol(NUMPY_SYMBOL, scipy_address if numpy_address is None else numpy_address)


_register()
_INTEGER, _DOUBLE = types.CPointer(types.int64), types.CPointer(types.float64)
#: dgesv(n, nrhs, a, lda, ipiv, b, ldb, info), Fortran's calling convention: every argument by pointer.
_SIGNATURE = types.void(_INTEGER, _INTEGER, _DOUBLE, _INTEGER, _INTEGER, _DOUBLE, _INTEGER, _INTEGER)
_numpy_dgesv = types.ExternalFunction(NUMPY_SYMBOL, _SIGNATURE)
_scipy_dgesv = types.ExternalFunction(SCIPY_SYMBOL, _SIGNATURE)


@njit(cache=True)
def dgesv_into(matrix: np.ndarray, rhs: np.ndarray, out: np.ndarray, numpy: bool) -> int:
    """x (n,) with A x = b into ``out`` by LAPACK's dgesv on a column-major copy of A (as numpy's solve and SciPy's
    ``lapack.dgesv`` pass it), numpy's (``numpy``) or SciPy's.

    Args:
        matrix: A (n, n), any layout (read); rhs: b (n,) (read); out: (n,) contiguous, written.

    Returns:
        LAPACK's info: 0, or i > 0 when U_ii is exactly zero (A singular; ``out`` is then not a solution).
    """
    n = matrix.shape[0]
    if n == 0:  # nothing to solve (a plant without vehicle velocities)
        return 0
    column_major = np.empty(n * n)
    for col in range(n):
        for row in range(n):
            column_major[col * n + row] = matrix[row, col]
    for row in range(n):
        out[row] = rhs[row]
    # n, nrhs, lda, ldb, info, then the pivots: 64-bit slots (module docstring)
    integers = np.zeros(5 + n, dtype=np.int64)
    integers[0], integers[1], integers[2], integers[3] = n, 1, n, n
    arguments = (integers[0:].ctypes, integers[1:].ctypes, column_major.ctypes, integers[2:].ctypes,
                 integers[5:].ctypes, out.ctypes, integers[3:].ctypes, integers[4:].ctypes)
    if numpy:
        _numpy_dgesv(*arguments)
    else:
        _scipy_dgesv(*arguments)
    return integers[4]


@njit(cache=True)
def solve_into(matrix: np.ndarray, rhs: np.ndarray, out: np.ndarray) -> bool:
    """x (n,) with A x = b into ``out``, as ``numpy.linalg.solve`` computes it (:func:`dgesv_into` with numpy's
    LAPACK).

    Args:
        matrix: A (n, n), any layout (read); rhs: b (n,) (read); out: (n,) contiguous, written.

    Returns:
        False when A is singular (LAPACK's info > 0) or x is not finite: ``out`` is then not a solution.
    """
    if dgesv_into(matrix, rhs, out, True) != 0:
        return False
    for row in range(out.shape[0]):
        if not np.isfinite(out[row]):
            return False
    return True
