"""Whether a Monte Carlo volume has converged: its change over the last doubling of the samples.

`monte_carlo` measures each frame's volume at N/8, N/4, N/2 and N samples (`WorkspaceResult.convergence`).
An occupied-voxel volume only grows with more samples, and by less at every doubling; when the last doubling
(N/2 -> N) still adds more than ``tolerance`` of the volume, the reported volume is short of the workspace
and more samples would give a larger one. The suggestion extrapolates the shrinking growth geometrically
from the last two doublings (the growth per doubling is taken to shrink by the same ratio again).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from ..errors import WorkspaceInputError

#: Default tolerance on the relative volume change over the last doubling of the samples (1 %).
CONVERGENCE_TOLERANCE = 0.01
#: The most doublings a suggestion extrapolates (beyond that: "many more samples or a coarser voxel").
MAX_EXTRAPOLATED_DOUBLINGS = 10


@dataclass(frozen=True)
class VolumeConvergence:
    """The convergence of one frame's volume.

    Attributes:
        converged: the last doubling changed the volume by at most ``tolerance`` (False when not measured).
        change: relative change ``|V(N) - V(N/2)| / V(N)`` over the last doubling [-] (NaN: fewer than two
            distinct sample counts, or a zero volume).
        previous_change: the same over the doubling before (N/4 -> N/2), NaN when not measured.
        samples_from, samples_to: the sample counts of the last doubling.
        tolerance: the tolerance [-].
        suggested_samples: a sample count expected to converge (None when converged or not extrapolated).
    """

    converged: bool
    change: float
    previous_change: float
    samples_from: int
    samples_to: int
    tolerance: float
    suggested_samples: int | None

    def as_dict(self) -> dict:
        """Plain JSON types for metrics.json (NaN becomes None)."""
        def number(value: float) -> float | None:
            return None if math.isnan(value) else float(value)

        return {"converged": self.converged, "change": number(self.change),
                "previous_change": number(self.previous_change), "samples_from": self.samples_from,
                "samples_to": self.samples_to, "tolerance": self.tolerance,
                "suggested_samples": self.suggested_samples}

    def status(self, frame: str) -> str:
        """One line: ``ee           volume converged: +0.65 % over the last doubling (100000 -> 200000 samples;
        tolerance 1 %)``."""
        if math.isnan(self.change):
            return f"{frame:<12} volume convergence not measured (fewer than two sample counts, or no volume)"
        state = "converged" if self.converged else "NOT converged"
        return (f"{frame:<12} volume {state}: {100 * self.change:+.2f} % over the last doubling "
                f"({self.samples_from} -> {self.samples_to} samples; tolerance {100 * self.tolerance:g} %)")

    def warning(self, frame: str) -> str | None:
        """The warning of a volume that has not converged (what more samples would do), None when converged."""
        if self.converged:
            return None
        if math.isnan(self.change):
            return f"the {frame} volume convergence could not be measured: use more samples (-n)"
        if self.suggested_samples is not None:
            more = f"extrapolated, about -n {self.suggested_samples} converge"
        else:
            more = (f"extrapolated, more than -n {self.samples_to * 2 ** MAX_EXTRAPOLATED_DOUBLINGS} would be "
                    f"needed")
        return (f"the {frame} volume has not converged: the last doubling of the samples added "
                f"{100 * self.change:.2f} % (tolerance {100 * self.tolerance:g} %), so more samples give a larger "
                f"volume; {more} (or use a coarser --voxel)")


def relative_change(before: float, after: float) -> float:
    """|after - before| / after, NaN when ``after`` is 0 and they differ, 0 when both are 0."""
    if after == before:
        return 0.0
    return abs(after - before) / after if after > 0 else math.nan


def volume_convergence(series: Sequence[tuple[int, float]],
                       tolerance: float = CONVERGENCE_TOLERANCE) -> VolumeConvergence:
    """The convergence of a volume from its (samples, volume [m^3]) series, increasing sample counts.

    Args:
        series: e.g. [(N/8, V), (N/4, V), (N/2, V), (N, V)] (`WorkspaceResult.convergence` of a frame).
        tolerance: the largest relative change over the last doubling of a converged volume (> 0).

    Raises:
        WorkspaceInputError: a tolerance that is not a finite number > 0.
    """
    if isinstance(tolerance, bool) or not isinstance(tolerance, (int, float)) or not (
            math.isfinite(tolerance) and tolerance > 0):
        raise WorkspaceInputError(f"the convergence tolerance must be a number > 0 (e.g. 0.01 for 1 %), "
                                  f"got {tolerance!r}")
    points = sorted({int(n): float(v) for n, v in series}.items())
    if len(points) < 2:
        samples = points[-1][0] if points else 0
        return VolumeConvergence(False, math.nan, math.nan, samples, samples, float(tolerance), None)
    (n1, v1), (n2, v2) = points[-2], points[-1]
    change = relative_change(v1, v2)
    previous = relative_change(points[-3][1], v1) if len(points) >= 3 else math.nan
    converged = not math.isnan(change) and change <= tolerance
    suggested = None
    if not converged and not math.isnan(change):
        suggested = suggest_samples(n2, change, previous, tolerance)
    return VolumeConvergence(converged, change, previous, n1, n2, float(tolerance), suggested)


def suggest_samples(samples: int, change: float, previous: float, tolerance: float) -> int | None:
    """A sample count whose last doubling is expected to change the volume by at most ``tolerance``.

    The growth per doubling is extrapolated with the ratio of the last two (change / previous); without a
    shrinking growth to extrapolate, four times the samples. None beyond `MAX_EXTRAPOLATED_DOUBLINGS`.
    """
    ratio = change / previous if previous and not math.isnan(previous) and previous > 0 else math.nan
    if not (0 < ratio < 1):
        return 4 * samples
    doublings = math.ceil(math.log(tolerance / change) / math.log(ratio))
    if doublings > MAX_EXTRAPOLATED_DOUBLINGS:
        return None
    return samples * 2 ** max(doublings, 1)
