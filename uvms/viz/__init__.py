"""Pictures: ``plotting`` (the figures of a run), ``drawing`` (headless configuration pictures and animations),
``viewer/`` (the 3-D browser viewer, extra ``viz``, and its ``teach`` sliders for notebooks).

Submodules are imported on use: matplotlib, viser and ipywidgets load only when asked for.
"""
