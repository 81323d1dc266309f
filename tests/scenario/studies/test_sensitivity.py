"""The numbers of a study's summary (uvms.scenario.studies.sensitivity): Wilson interval, percentiles, Spearman
ranking."""

from __future__ import annotations

import math

import numpy as np
import pytest

from uvms.scenario.studies.sensitivity import correlation_ratio, pass_rate, percentiles, sensitivity, spearman


@pytest.mark.parametrize(("passed", "trials"), [(8, 10), (0, 12), (64, 64), (37, 64)])
def test_pass_rate_is_the_wilson_score_interval(passed, trials):
    z = 1.959963984540054  # the 97.5 % normal quantile
    p = passed / trials
    centre = (p + z**2 / (2 * trials)) / (1 + z**2 / trials)
    half = z / (1 + z**2 / trials) * math.sqrt(p * (1 - p) / trials + z**2 / (4 * trials**2))
    rate = pass_rate(passed, trials)
    assert rate["rate"] == p and rate["ci_method"] == "wilson"
    assert rate["ci_low"] == pytest.approx(max(centre - half, 0.0), abs=1e-12)
    assert rate["ci_high"] == pytest.approx(min(centre + half, 1.0), abs=1e-12)


def test_percentiles_of_the_finite_values_only():
    numbers = percentiles([float(v) for v in range(101)] + [math.nan])
    assert numbers["count"] == 101 and numbers["p5"] == 5.0 and numbers["p50"] == 50.0 and numbers["p95"] == 95.0
    assert numbers["mean"] == 50.0 and (numbers["min"], numbers["max"]) == (0.0, 100.0)
    assert percentiles([math.nan]) is None


def test_spearman_ranks_the_key_the_metric_depends_on_first(rng):
    x, noise = rng.uniform(0, 1, 200), rng.uniform(0, 1, 200)
    table = [{"a": float(a), "b": float(b), "c": "x", "m": float(a**3), "pass": bool(a > 0.5), "error": ""}
             for a, b in zip(noise, x)]
    ranking = sensitivity(table, ["b", "a", "c"], ["m", "pass"])
    assert [e["key"] for e in ranking["m"]] == ["a", "b", "c"]
    assert ranking["m"][2] == {"key": "c", "eta2": 0.0, "rho": None, "p_value": None}  # one string: no order, no effect
    assert ranking["m"][0]["eta2"] > 0.95 and ranking["m"][1]["eta2"] < 0.15  # noise: about (14 - 1) / 199
    assert ranking["m"][0]["rho"] == pytest.approx(1.0) and ranking["m"][0]["p_value"] < 1e-100
    assert abs(ranking["m"][1]["rho"]) < 0.25 and ranking["pass"][0]["key"] == "a"
    assert ranking["pass"][0]["rho"] == pytest.approx(np.sqrt(3) / 2, abs=0.06)  # point-biserial of ranks: sqrt(3)/2
    assert spearman([1, 2, 3], [5, 5, 5]) == {"rho": None, "p_value": None}  # constant: no rho, never NaN


def test_the_correlation_ratio_sees_an_effect_rank_correlation_misses(rng):
    x = rng.uniform(-1, 1, 400)
    y = x**2  # a current from either side: no monotonic trend
    assert abs(spearman(x, y)["rho"]) < 0.15
    assert correlation_ratio(x, y) > 0.95  # 20 bins: the within-bin variance is about 1 % of the total
    labels = ["left", "right", "left", "mid", "right", "mid"]
    values = [1.0, 5.0, 3.0, 2.0, 7.0, 2.0]  # means 2, 6, 2; grand mean 10/3
    between = 2 * ((2 - 10 / 3) ** 2 + (6 - 10 / 3) ** 2 + (2 - 10 / 3) ** 2)
    total = sum((v - 10 / 3) ** 2 for v in values)
    assert correlation_ratio(labels, values) == pytest.approx(between / total, abs=1e-15)
    assert correlation_ratio(x[:10], np.ones(10)) is None
