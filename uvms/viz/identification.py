"""Figures of a hydrodynamic identification (:func:`uvms.dynamics.identification.identify.identify`).

``prediction.png``: per body axis, on the held-out segment, the measured twist and the twist simulated from its
first state under the logged wrench and arm motion, with the identified and with the prior hydrodynamics.
``residuals.png``: per axis, the wrench residual of the fit [N, N m] over the fitted segment.
"""

from __future__ import annotations

import os
from pathlib import Path

from matplotlib.figure import Figure

from ..dynamics.identification.identify import IdentificationResult
from ..dynamics.identification.model import AXES
from ..io import outputs

#: The unit of each body axis' velocity and wrench.
VELOCITY_UNITS = ("m/s",) * 3 + ("rad/s",) * 3
WRENCH_UNITS = ("N",) * 3 + ("N m",) * 3


def prediction_figure(result: IdentificationResult, title: str = "") -> Figure:
    """Measured vs simulated body twist per axis on the held-out segment (a 3 x 2 grid).

    Raises:
        IdentificationError: the result has no held-out segment (holdout = 0).
    """
    from ..errors import IdentificationError

    prediction = result.prediction
    if prediction is None:
        raise IdentificationError("the identification kept no held-out segment (holdout = 0): nothing to predict")
    fits = result.metrics["held_out"]
    figure = Figure(figsize=(10, 7), layout="constrained")
    axes = figure.subplots(3, 2, sharex=True).T.reshape(-1)
    for index, axis in enumerate(axes):
        name = AXES[index]
        identified, prior = fits["fit_percent_identified"], fits["fit_percent_prior"]
        axis.plot(prediction.t, prediction.measured[:, index], color="0.55", linewidth=0.8, label="measured")
        axis.plot(prediction.t, prediction.prior[:, index], color="C1", linestyle="--", linewidth=1,
                  label="prior model" + ("" if prior is None else f" (fit {prior[name]:.1f} %)"))
        axis.plot(prediction.t, prediction.identified[:, index], color="C0", linewidth=1.2,
                  label="identified" + ("" if identified is None else f" (fit {identified[name]:.1f} %)"))
        axis.set_ylabel(f"{name} [{VELOCITY_UNITS[index]}]")
        axis.grid(True, alpha=0.3)
        axis.legend(fontsize=7, loc="upper right")
    for axis in (axes[2], axes[5]):
        axis.set_xlabel("t [s]")
    figure.suptitle(title or f"held-out prediction of the body twist of {result.link} (simulated from its first "
                    "state)")
    return figure


def residual_figure(result: IdentificationResult, title: str = "") -> Figure:
    """The wrench residuals of the fit per axis (a 3 x 2 grid)."""
    figure = Figure(figsize=(10, 7), layout="constrained")
    axes = figure.subplots(3, 2, sharex=True).T.reshape(-1)
    rms = result.metrics["wrench_residual_rms"]
    for index, axis in enumerate(axes):
        name = AXES[index]
        axis.plot(result.residual_t, result.residuals[:, index], color="C3", linewidth=0.7)
        axis.axhline(0.0, color="k", linewidth=0.6)
        axis.set_ylabel(f"{name} [{WRENCH_UNITS[index]}]")
        axis.set_title(f"RMS {rms[name]:.3g} {WRENCH_UNITS[index]}", fontsize=8)
        axis.grid(True, alpha=0.3)
    for axis in (axes[2], axes[5]):
        axis.set_xlabel("t [s]")
    figure.suptitle(title or f"wrench residuals of the fit (measured - model), {result.link}")
    return figure


def identification_figures(result: IdentificationResult, folder: str | os.PathLike) -> list[Path]:
    """Write ``prediction.png`` (when there is a held-out segment) and ``residuals.png`` into ``folder``."""
    folder = Path(folder)
    written = []
    figures = {"residuals.png": residual_figure(result)}
    if result.prediction is not None:
        figures["prediction.png"] = prediction_figure(result)
    for name, figure in figures.items():
        outputs.save_figure(figure, folder / name)
        written.append(folder / name)
    return written
