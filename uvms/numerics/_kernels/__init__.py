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
loop), :mod:`.runge_kutta` (an RK4 step's vector arithmetic), :mod:`.allocation` (the thrust allocation's
pseudo-inverse step), :mod:`.vehicle` (the vehicle loops' vector arithmetic).

Import a kernel from its module; this package imports nothing, so ``import uvms`` never loads numba.

Each module imports numba, so it is loaded where a solver first uses it. The kernels compile at their
first call and are cached on disk in this package's ``__pycache__`` (or in numba's user cache when the
package folder is read-only): the first solve after an install or an edit compiles the kernels it calls
(about 3.5 s for the CLIK's, 7 s for the set-based solver's); every later process loads the machine code
(numba's import and first call, about 0.5-1 s together). numba keys a cached kernel on its own file only:
after editing a module, delete this package's ``__pycache__`` so that the kernels of other modules that call
into it are compiled again.
"""
