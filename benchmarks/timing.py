"""Timing as ratios to a reference call timed beside it (numpy and the standard library only: placo's environment
imports it too)."""

from __future__ import annotations

import timeit
from collections.abc import Callable

import numpy as np


def interleaved_ratios(calls: dict[str, Callable[[], object]], reference: Callable[[], object], repeat: int,
                       rounds: int = 10) -> tuple[dict[str, float], float]:
    """Each call's time over the reference's, both timed back to back in every round; the median over the rounds.

    The machine's speed drifts by up to 2x within a minute (shared cores): a reference timed once apart from the
    calls moves every ratio with it, a reference timed beside each call cancels the drift.

    Args:
        calls: label -> the call timed; reference: the call every time is divided by (``pin.forwardKinematics``).
        repeat: calls of each per label over all rounds; rounds: timing rounds.

    Returns:
        ({"pin.forwardKinematics": 1.0, label: median ratio}, median reference time [s]).
    """
    per_round = max(1, repeat // rounds)
    samples: dict[str, list[float]] = {label: [] for label in calls}
    references = []
    for _ in range(rounds):
        for label, call in calls.items():
            fk = timeit.timeit(reference, number=5 * per_round) / (5 * per_round)
            samples[label].append(timeit.timeit(call, number=per_round) / per_round / fk)
            references.append(fk)
    return ({"pin.forwardKinematics": 1.0, **{label: float(np.median(v)) for label, v in samples.items()}},
            float(np.median(references)))
