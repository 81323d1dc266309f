"""Numerics below every solver and the dynamics: the inverses (pinv, weighted, DLS with fixed or variable
damping), input checks, fixed-step integrators on the configuration manifold and the compiled kernels
(numba, loaded at first use).
"""
