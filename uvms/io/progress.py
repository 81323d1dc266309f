"""The progress bar of long computations: ``tqdm.auto``, imported once and quietly.

``tqdm.auto`` warns in a notebook without ipywidgets and then falls back to a text bar; that warning says
nothing a user can act on, so it is silenced here, in one place.
"""

import warnings

with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    from tqdm.auto import tqdm

__all__ = ["tqdm"]
