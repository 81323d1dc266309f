"""Compiled dense kernels of the solvers' inner loops (numba, nopython mode), one module per concern.

A hot loop's step is a handful of products of (6, nv) matrices, a (k, k) Cholesky solve and a few
vector updates. Each numpy call costs 0.3-1 us of interpreter and dispatch overhead on arrays this
small, about what the arithmetic itself costs, so a step written as numpy calls is bounded by their
number. Here the whole dense part of a step is one compiled call; Pinocchio still computes every pose,
Jacobian, logarithm and integration.

Modules: :mod:`.svd` (the Jacobi SVD and the damped inverse), :mod:`.dense` (products in loops, the
Cholesky/DLS solve), :mod:`.weighted` (the weighted inverse), :mod:`.icat` (the set-based recursion),
:mod:`.qr` (the pivoted QR triangle, the few rows with a matrix's Gram matrix), :mod:`.clik` (the CLIK's
solution and joint-limit motion), :mod:`.pose` (pose errors, the pose DLS step), :mod:`.activation` (objectives'
bells), :mod:`.boxes` (position and velocity boxes, saturation scaling), :mod:`.distance` (the distance Jacobian
of collision pairs), :mod:`.hydro` (the plant's hydrodynamic terms, every link in one pass), :mod:`.plant_stage`
(a plant evaluation's terms, accelerations, the thrusters' wrench and lag, and the actuation series after the
loop), :mod:`.runge_kutta` (an RK4 step's vector arithmetic and tangent solves), :mod:`.solve` (a square solve with
numpy's or SciPy's own LAPACK, their numbers), :mod:`.allocation` (the thrust allocation's pseudo-inverse step),
:mod:`.vehicle` (the vehicle loops' vector arithmetic).

A helper that a hot kernel calls with arrays, in a loop or per call, is ``@njit(inline="always")``: numba then
inlines it into its caller before it counts references. Called across a function boundary, each array argument is
an atomic increment and decrement of its reference count (a locked instruction, which drains the store buffer), and
these were a quarter to a third of the plant's kernels' time and a seventh of the iCAT's (sampled, issue 46); the
arithmetic, and so every number, is the same. Only the helpers whose inlining paid are marked: each inlined copy is
compiled again in every caller (a run's first compile after an install: about 8 s more for the intervention).

Import a kernel from its module; this package imports no numba, so ``import uvms`` never loads it. Code that
must not load numba before it computes (``import uvms``, a kinematic run) names a kernel by a :class:`Kernel`,
imported at its first use.

Each module imports numba, so it is loaded where a solver first uses it. The kernels compile at their
first call and are cached on disk in this package's ``__pycache__`` (or in numba's user cache when the
package folder is read-only): the first solve after an install or an edit compiles the kernels it calls
(about 3.5 s for the CLIK's, 7 s for the set-based solver's); every later process loads the machine code
(numba's import and first call, about 0.5-1 s together). numba keys a cached kernel on its own file only:
after editing a module, delete this package's ``__pycache__`` so that the kernels of other modules that call
into it are compiled again.
"""

from __future__ import annotations

from collections.abc import Callable
from importlib import import_module


class Kernel:
    """A compiled kernel named by its module of this package and its name, imported at the first use: numba loads
    there, not with the module that names it. Call it as ``(KERNEL.function or KERNEL.load())(...)``: after the
    first use one attribute read, no call.

    Args:
        module: the module's name in this package (e.g. "vehicle"); name: the kernel's name in it.
    """

    __slots__ = ("module", "name", "function")

    def __init__(self, module: str, name: str) -> None:
        self.module, self.name = module, name
        self.function: Callable | None = None  # bound by :meth:`load`

    def load(self) -> Callable:
        """The kernel (its module imported at the first call; numba compiles or loads it at its own first call)."""
        if self.function is None:
            self.function = getattr(import_module(f"{__name__}.{self.module}"), self.name)
        return self.function
