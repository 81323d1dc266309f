"""Hydrodynamic identification from a log: the fit (``identify``), the log and its smoothing (``data``), the
regression (``model``), the least squares with priors (``fit``), a constant current (``current``) and the held-out
check (``predict``)."""
