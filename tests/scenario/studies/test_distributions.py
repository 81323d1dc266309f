"""The distributions of `uvms study` (uvms.scenario.studies.distributions): parsing as data, moments, truncation,
seeds."""

from __future__ import annotations

import math

import numpy as np
import pytest

from uvms.errors import StudyError
from uvms.scenario.studies.distributions import FORMS, parse_sample, parse_samples, sample_table, trial_seeds

N = 10_000  # standard errors about 1 % of sigma: tolerances of 4 of them


def column(text: str, method: str = "random", n: int = N, seed: int = 1) -> np.ndarray:
    return np.array([row[0] for row in sample_table([parse_sample(text)], n, seed, method)[1]])


@pytest.mark.parametrize("method", ["random", "lhs", "sobol"])
def test_moments_of_each_distribution(method):
    normal = column("solver.alpha=normal(2.0, 0.5)", method)
    assert abs(normal.mean() - 2.0) < 0.02 and abs(normal.var() - 0.25) < 0.015
    uniform = column("solver.alpha=uniform(1, 3)", method)
    assert uniform.min() >= 1 and uniform.max() <= 3
    assert abs(uniform.mean() - 2.0) < 0.025 and abs(uniform.var() - 1 / 3) < 0.015
    logs = np.log(column("solver.alpha=loguniform(1, 100)", method))
    assert abs(logs.mean() - math.log(10)) < 0.06 and abs(logs.var() - math.log(100) ** 2 / 12) < 0.06
    half = column("solver.damping=normal(0, 1)", method)  # damping >= 0: truncated to a half-normal
    assert half.min() >= 0 and abs(half.mean() - math.sqrt(2 / math.pi)) < 0.025
    assert abs(half.var() - (1 - 2 / math.pi)) < 0.02
    values, counts = np.unique(column("solver.alpha=choice([1, 2, 5])", method), return_counts=True)
    assert values.tolist() == [1, 2, 5] and np.all(np.abs(counts / N - 1 / 3) < 0.02)


def test_explicit_truncation_and_a_strict_lower_bound():
    cut = column("model.args.l1=normal(0.4, 0.1, 0.3, 0.5)")
    assert cut.min() >= 0.3 and cut.max() <= 0.5
    assert abs(cut.var() - 0.1**2 * (1 - 2 * 0.24197 / 0.68269)) < 6e-4  # truncnorm variance at +-1 sigma
    strict = column("outputs.position_tolerance=normal(0, 1e-3)", n=2000)
    assert strict.min() > 0  # the tolerance must be > 0: never exactly the bound
    unbounded = column("model.args.l1=normal(0, 1)")  # xacro args have no schema bounds
    assert unbounded.min() < -3 and unbounded.max() > 3


def test_trial_seeds_and_values_do_not_depend_on_n():
    seeds5, rows5 = sample_table(parse_samples(["solver.gain=uniform(0, 1)", "model.args.l1=normal(1, 0.1)"]), 5, 9)
    seeds9, rows9 = sample_table(parse_samples(["solver.gain=uniform(0, 1)", "model.args.l1=normal(1, 0.1)"]), 9, 9)
    assert seeds9[:5] == seeds5 == trial_seeds(9, 5) and rows9[:5] == rows5
    assert seeds5[0] == int(np.random.SeedSequence(9).spawn(1)[0].generate_state(1, dtype=np.uint64)[0])
    u = np.random.default_rng(seeds5[2]).random(2)  # a row is reproducible from its recorded seed alone
    assert rows5[2][0] == pytest.approx(u[0], abs=1e-15)
    assert len(set(seeds9)) == 9 and sample_table(parse_samples(["solver.gain=uniform(0, 1)"]), 5, 10)[0] != seeds5


def test_a_latin_hypercube_puts_one_trial_in_each_stratum():
    values = column("solver.alpha=uniform(0, 1)", "lhs", n=50)
    assert sorted(np.floor(values * 50).astype(int).tolist()) == list(range(50))


@pytest.mark.parametrize(("text", "words"), [
    ("solver.gain", "expects KEY=DIST"),
    ("gain=uniform(0, 1)", "expects KEY=DIST"),
    ("solver.gain=gauss(0, 1)", "not a known distribution"),
    ("solver.gain=normal(0, 1, 2)", "normal takes 2 or 4 finite numbers"),
    ("solver.gain=normal(0, -1)", "sigma must be > 0"),
    ("solver.gain=normal(0, nan)", "finite numbers"),
    ("solver.gain=uniform(2, 1)", "a < b"),
    ("solver.gain=loguniform(0, 1)", "0 < a"),
    ("solver.gain=uniform(__import__('os'), 1)", "not a TOML list"),
    ("solver.gain=choice(1, 2)", "one non-empty list"),
    ("solver.gain=choice([1, 1])", "distinct"),
    ("solver.damping=uniform(-1, 1)", r"solver.damping must lie in \[0, 1e\+06\]"),
    ("outputs.position_tolerance=uniform(0, 1)", r"must lie in \(0, 1e\+06\]"),
    ("solver.gain=normal(5e6, 1)", "within 8 sigma"),
])
def test_bad_distributions_name_the_key_and_the_valid_forms(text, words):
    with pytest.raises(StudyError, match=words) as caught:
        parse_sample(text)
    assert ("expects KEY=DIST" in str(caught.value) or str(caught.value).startswith(f"--samples {text.split('=')[0]}="))
    assert FORMS in str(caught.value)


def test_each_key_once():
    with pytest.raises(StudyError, match="each key once"):
        parse_samples(["solver.gain=uniform(0, 1)", "solver.gain=uniform(1, 2)"])
    with pytest.raises(StudyError, match="each key once"):
        parse_samples(["plant.current=uniform(0, 1)", "plant.current[0]=uniform(0, 1)"])
    with pytest.raises(StudyError, match="at least one"):
        parse_samples([])


def test_a_truncation_that_collapses_the_normal_is_refused():
    with pytest.raises(StudyError, match=r"solver.damping=normal\(0.5, 1e50\): the truncation to \[0, 1e\+06\] "
                                         r"collapses this normal: the interval keeps 0 of its mass, and its samples "
                                         r"would be 0.5 to 0.5 \(1 % to 99 %\).* sample uniform\(0, 1e\+06\)"):
        parse_sample("solver.damping=normal(0.5, 1e50)")  # every trial 0.5, before
    with pytest.raises(StudyError, match="collapses this normal"):
        parse_sample("solver.damping=normal(0.5, 1e20)")  # quantiles outside the interval
    wide = column("solver.damping=normal(0.5, 1e7)", n=2000)  # still a distribution: nearly flat on [0, 1e6]
    assert wide.min() >= 0 and wide.max() <= 1e6 and abs(np.median(wide) - 5e5) < 5e4
