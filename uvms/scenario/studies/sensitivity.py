"""The numbers of a study's table: pass rate with its confidence interval, percentiles, sensitivity ranking.

Pass rate: the trials whose verdict is ok (:mod:`uvms.scenario.verdict`) among all trials, a failed or killed
trial counting as not passed; its 95 % interval is Wilson's score interval
(``scipy.stats.binomtest(k, n).proportion_ci(method="wilson")``), which keeps its coverage near 0 and 1 where the
normal approximation does not.

Sensitivity, for each metric (and ``pass``) and each sampled key, over the trials that ran:

- Spearman's rank correlation rho with its two-sided p-value (``scipy.stats.spearmanr``, numeric keys): the sign
  and strength of a monotonic effect;
- a first-order variance-based index from the same samples, the correlation ratio eta^2 = Var(E[Y | X]) / Var(Y)
  with E[Y | X] the mean of Y in each of ``round(sqrt(n))`` equal-count bins of X (each value of a choice its own
  bin): the fraction of the metric's variance the key explains alone, monotonic or not (a current from either
  side). A key without effect still gets about (bins - 1) / (n - 1), the ``eta2_noise_floor`` of the summary.

Keys are ranked by eta^2. A key or metric that does not vary has no rho or index (``null``), never NaN.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

PERCENTILES = (5, 25, 50, 75, 95)
CONFIDENCE = 0.95


def pass_rate(passed: int, trials: int) -> dict:
    """``{"passed", "trials", "rate", "ci_low", "ci_high", "confidence", "ci_method"}`` (Wilson score interval)."""
    from scipy.stats import binomtest

    interval = binomtest(passed, trials).proportion_ci(confidence_level=CONFIDENCE, method="wilson")
    return {"passed": passed, "trials": trials, "rate": passed / trials, "ci_low": float(interval.low),
            "ci_high": float(interval.high), "confidence": CONFIDENCE, "ci_method": "wilson"}


def percentiles(values: Sequence[float]) -> dict | None:
    """Mean, min, max and :data:`PERCENTILES` of the finite ``values`` (None if there are none)."""
    finite = np.array([v for v in values if isinstance(v, (int, float)) and math.isfinite(v)], dtype=float)
    if finite.size == 0:
        return None
    numbers = {f"p{p}": float(np.percentile(finite, p)) for p in PERCENTILES}
    return {"count": int(finite.size), "mean": float(finite.mean()), "min": float(finite.min()),
            "max": float(finite.max()), **numbers}


def is_numeric(values: Sequence) -> bool:
    return all(isinstance(v, (int, float)) for v in values)


def spearman(x: Sequence[float], y: Sequence[float]) -> dict:
    """``{"rho", "p_value"}`` of Spearman's rank correlation; both None if x or y is constant or too short."""
    from scipy.stats import spearmanr

    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    if len(x) < 3 or np.ptp(x) == 0 or np.ptp(y) == 0:
        return {"rho": None, "p_value": None}
    result = spearmanr(x, y)
    return {"rho": float(result.statistic), "p_value": float(result.pvalue)}


def bin_count(n: int) -> int:
    """The bins of the correlation ratio for n samples: round(sqrt(n)), at least 2."""
    return max(2, round(math.sqrt(n)))


def correlation_ratio(x: Sequence, y: Sequence[float]) -> float | None:
    """eta^2 = Var(E[Y | X]) / Var(Y), E[Y | X] per equal-count bin of X (per value if X is not numeric).

    Returns:
        eta^2 in [0, 1], or None if Y does not vary or there are fewer than 3 samples.
    """
    y = np.asarray(y, dtype=float)
    if len(y) < 3 or np.ptp(y) == 0:
        return None
    if is_numeric(x):
        order = np.argsort(np.asarray(x, dtype=float), kind="stable")
        groups = [y[part] for part in np.array_split(order, bin_count(len(y)))]
    else:
        labels = [repr(v) for v in x]
        groups = [y[[i for i, label in enumerate(labels) if label == value]] for value in dict.fromkeys(labels)]
    between = sum(len(g) * (g.mean() - y.mean()) ** 2 for g in groups if len(g))
    return float(between / ((y - y.mean()) ** 2).sum())


def sensitivity(table: Sequence[dict], keys: Sequence[str], outcomes: Sequence[str]) -> dict:
    """Per outcome: the keys ranked by eta^2 (``[{"key", "eta2", "rho", "p_value"}, ...]``), over the trials that
    ran."""
    ran = [row for row in table if not row["error"]]
    ranking = {}
    for outcome in outcomes:
        rows = [row for row in ran if isinstance(row[outcome], (bool, int, float)) and math.isfinite(row[outcome])]
        entries = []
        for key in keys:
            xs, ys = [row[key] for row in rows], [float(row[outcome]) for row in rows]
            rank = spearman(xs, ys) if is_numeric(xs) else {"rho": None, "p_value": None}  # strings: no order
            entries.append({"key": key, "eta2": correlation_ratio(xs, ys), **rank})
        entries.sort(key=lambda e: -e["eta2"] if e["eta2"] is not None else 1.0)
        ranking[outcome] = entries
    return ranking


def summarize(table: Sequence[dict], keys: Sequence[str], metrics: Sequence[str]) -> dict:
    """The content of ``summary.json``: pass rate, failures, percentiles of each metric and of each key, ranking."""
    failed = [row["trial"] for row in table if row["error"]]
    return {
        "pass_rate": pass_rate(sum(bool(row["pass"]) for row in table), len(table)),
        "failed_trials": failed,
        "metrics": {metric: percentiles([row[metric] for row in table]) for metric in metrics},
        "samples": {key: percentiles([row[key] for row in table]) for key in keys
                    if is_numeric([row[key] for row in table])},
        "sensitivity": sensitivity(table, keys, [*metrics, "pass"]),
        "sensitivity_method": "keys ranked by the correlation ratio eta2 (first-order variance-based index, binned); "
                              "Spearman's rho with its two-sided p-value (scipy.stats.spearmanr)",
        "eta2_noise_floor": (bin_count(len(table) - len(failed)) - 1) / max(len(table) - len(failed) - 1, 1),
    }


__all__ = ["correlation_ratio", "pass_rate", "percentiles", "sensitivity", "spearman", "summarize"]
