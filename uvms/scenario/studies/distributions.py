"""The distributions of a Monte Carlo study: ``KEY=DIST`` parsed as data, and the table of sampled values.

A distribution is written ``normal(mu, sigma)``, ``normal(mu, sigma, low, high)`` (truncated to [low, high]),
``uniform(a, b)``, ``loguniform(a, b)`` (0 < a < b: uniform in log) or ``choice([v1, v2, ...])`` (equally
likely values: numbers, strings or booleans). The arguments are read as a TOML array (never evaluated). A key is
any ``--set`` key (``solver.gain``, ``model.args.l1``, ``plant.current``...), or one element of a list-valued
key, ``plant.current[0]``.

Where the scenario spec bounds a key (its :class:`~uvms.scenario.spec.keys.Bound`, and ``|x| <=``
:data:`~uvms.scenario.spec.keys.MAX_MAGNITUDE` for every key but ``model.args``), a normal distribution is truncated
to the bounds (``scipy.stats.truncnorm``: the normal conditioned on the interval), and a uniform or loguniform one
must lie inside them.

Every value is the inverse CDF (``ppf``) of a number u in (0, 1): u is drawn per trial from the trial's own seed
(method ``random``; ``SeedSequence(seed).spawn(n)``, so trial k has the same values whatever n is), or from a
Latin hypercube or a scrambled Sobol sequence of all trials (``scipy.stats.qmc``; methods ``lhs`` and ``sobol``).
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...errors import StudyError
from ..schema import parse_value
from ..spec import MAX_MAGNITUDE, key_of

FORMS = ("normal(mu, sigma), normal(mu, sigma, low, high), uniform(a, b), loguniform(a, b) with 0 < a < b, "
         "choice([v1, v2, ...])")
METHODS = ("random", "lhs", "sobol")
KEY_PATTERN = re.compile(r"[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z0-9_-]+)+(\[(\d{1,3})\])?")
CALL_PATTERN = re.compile(r"\s*([a-z]+)\s*\((.*)\)\s*", re.S)
#: u is kept this far inside (0, 1): ppf(0) of a normal is -inf; a scrambled Sobol point is never 0 but a random
#: double can be.
EDGE = 2.0**-53


@dataclass(frozen=True)
class Distribution:
    """One sampled key's distribution; :meth:`ppf` maps u in (0, 1) to values.

    Attributes:
        kind: ``"normal"``, ``"uniform"``, ``"loguniform"`` or ``"choice"``.
        parameters: (mu, sigma), (a, b), or the values of a choice.
        low, high: the truncation of a normal (``-inf``/``inf``: none).
    """

    kind: str
    parameters: tuple
    low: float = -math.inf
    high: float = math.inf

    def ppf(self, u: np.ndarray) -> list:
        """The values at the quantiles ``u`` (shape (n,), in (0, 1)); floats, or the choice's own values."""
        u = np.clip(np.asarray(u, dtype=float), EDGE, 1.0 - EDGE)
        if self.kind == "choice":
            values = self.parameters
            return [values[min(int(x * len(values)), len(values) - 1)] for x in u]
        if self.kind == "uniform":
            a, b = self.parameters
            values = a + u * (b - a)
        elif self.kind == "loguniform":
            a, b = self.parameters
            values = np.exp(math.log(a) + u * (math.log(b) - math.log(a)))
        else:
            from scipy import stats

            mu, sigma = self.parameters
            if math.isinf(self.low) and math.isinf(self.high):
                values = stats.norm.ppf(u, loc=mu, scale=sigma)
            else:
                values = stats.truncnorm.ppf(u, (self.low - mu) / sigma, (self.high - mu) / sigma, loc=mu, scale=sigma)
        return [float(v) for v in values]

    def text(self) -> str:
        """The canonical form (stored in the study's spec)."""
        if self.kind == "choice":
            return f"choice({list(self.parameters)!r})"
        arguments = [*self.parameters, *((self.low, self.high) if self.kind == "normal" and
                                          not (math.isinf(self.low) and math.isinf(self.high)) else ())]
        return f"{self.kind}({', '.join(repr(float(a)) for a in arguments)})"


def key_bounds(key: str) -> tuple[float, float, bool]:
    """The interval the schema allows for ``key``: (low, high, whether low itself is excluded)."""
    base = key.split("[")[0]
    if base.startswith("model.args."):
        return -math.inf, math.inf, False  # xacro args: the model checks them (a failed trial says so)
    spec = key_of(base)
    if spec is None or spec.bound is None:
        return -MAX_MAGNITUDE, MAX_MAGNITUDE, False
    return spec.bound.low, MAX_MAGNITUDE, spec.bound.strict


def parse_sample(text: str) -> tuple[str, Distribution]:
    """``KEY=DIST`` -> (key, distribution).

    Raises:
        StudyError: not KEY=DIST, an unknown form, bad arguments (naming the key and the valid forms).
    """
    key, sep, spec = text.partition("=")
    key, spec = key.strip(), spec.strip()
    if not sep or not KEY_PATTERN.fullmatch(key) or not spec:
        count = " (the number of trials is -n N, [study] n)" if text.strip().isdigit() else ""
        raise StudyError(f"--samples expects KEY=DIST with KEY a scenario key (e.g. model.args.l1 or "
                         f"plant.current[0]) and DIST one of {FORMS}; got {text!r}{count}")
    return key, parse_distribution(key, spec)


def parse_distribution(key: str, spec: str) -> Distribution:
    """The distribution ``spec`` of ``key``, truncated to or checked against the key's bounds (:func:`key_bounds`)."""
    def bad(why: str) -> StudyError:
        return StudyError(f"--samples {key}={spec}: {why}; valid forms: {FORMS}")

    call = CALL_PATTERN.fullmatch(spec)
    if call is None or call.group(1) not in ("normal", "uniform", "loguniform", "choice"):
        raise bad("not a known distribution")
    kind, inner = call.groups()
    arguments = parse_value(f"[{inner}]")
    if not isinstance(arguments, list):
        raise bad(f"the arguments ({inner.strip()}) are not a TOML list of numbers")
    if kind == "choice":
        if len(arguments) != 1 or not isinstance(arguments[0], list) or not arguments[0]:
            raise bad("choice takes one non-empty list")
        values = arguments[0]
        if any(isinstance(v, (list, dict)) for v in values) or len({repr(v) for v in values}) != len(values):
            raise bad("the values of a choice are distinct numbers, strings or booleans")
        return Distribution("choice", tuple(values))
    counts = {"normal": (2, 4), "uniform": (2,), "loguniform": (2,)}[kind]
    if len(arguments) not in counts or not all(isinstance(a, (int, float)) and not isinstance(a, bool)
                                               and math.isfinite(a) for a in arguments):
        raise bad(f"{kind} takes {' or '.join(map(str, counts))} finite numbers")
    numbers = [float(a) for a in arguments]
    low, high, strict = key_bounds(key)
    allowed = f"{key} must lie in {'(' if strict else '['}{low:g}, {high:g}]"
    if kind == "normal":
        mu, sigma = numbers[:2]
        if sigma <= 0:
            raise bad("sigma must be > 0")
        cut = (max(numbers[2], low), min(numbers[3], high)) if len(numbers) == 4 else (low, high)
        if not cut[0] < cut[1] or not cut[0] - 8 * sigma < mu < cut[1] + 8 * sigma:
            raise bad(f"the truncation [{cut[0]:g}, {cut[1]:g}] must be an interval within 8 sigma of mu ({allowed})")
        distribution = Distribution("normal", (mu, sigma), *cut)
        collapse = truncation_collapse(distribution)
        if collapse:
            raise bad(collapse)
        return distribution
    a, b = numbers
    if not a < b:
        raise bad("a < b is required")
    if kind == "loguniform" and a <= 0:
        raise bad("loguniform needs 0 < a")
    if a < low or (strict and a == low) or b > high:
        raise bad(allowed)
    return Distribution(kind, (a, b))


def truncation_collapse(distribution: Distribution) -> str:
    """Why sampling a truncated normal would not give its distribution ("" if it would).

    With sigma far larger than the interval (``normal(0.5, 1e50)`` on [0, 1e6]), the interval keeps a vanishing
    share of the mass and ``truncnorm``'s quantiles lose their precision: they collapse onto one value (every
    trial alike) or fall outside the interval. Quantiles 1 %, 50 %, 99 % that are not increasing inside the
    interval, 1 %-99 % apart by at least 1e-3 of min(sigma, interval), are that case.
    """
    from scipy import stats

    (mu, sigma), low, high = distribution.parameters, distribution.low, distribution.high
    if math.isinf(low) and math.isinf(high):
        return ""
    q01, q50, q99 = distribution.ppf(np.array([0.01, 0.5, 0.99]))
    if low <= q01 < q50 < q99 <= high and q99 - q01 >= 1e-3 * min(sigma, high - low):
        return ""
    kept = float(stats.norm.cdf(high, mu, sigma) - stats.norm.cdf(low, mu, sigma))
    return (f"the truncation to [{low:g}, {high:g}] collapses this normal: the interval keeps {kept:.2g} of its mass, "
            f"and its samples would be {q01:g} to {q99:g} (1 % to 99 %), not a distribution over the interval; for "
            f"a flat distribution there sample uniform({low:g}, {high:g}), else give a sigma of the interval's size")


def parse_samples(texts: Sequence[str]) -> list[tuple[str, Distribution]]:
    """Several ``KEY=DIST``; each key once (an element ``KEY[i]`` and its whole list ``KEY`` not both)."""
    samples = [parse_sample(text) for text in texts]
    keys = [key for key, _ in samples]
    wholes = {key for key in keys if "[" not in key}
    clash = [key for key in keys if "[" in key and key.split("[")[0] in wholes]
    if not samples or len(set(keys)) != len(keys) or clash:
        raise StudyError(f"a study needs at least one --samples KEY=DIST ([study] samples) and each key once (a "
                         f"list and one of its elements not both), got {keys}")
    return samples


def trial_seeds(seed: int, n: int) -> list[int]:
    """One 64-bit seed per trial from ``numpy.random.SeedSequence(seed).spawn(n)`` (trial k's is the same for any n)."""
    return [int(child.generate_state(1, dtype=np.uint64)[0]) for child in np.random.SeedSequence(seed).spawn(n)]


def quantiles(method: str, seeds: Sequence[int], seed: int, dimensions: int) -> np.ndarray:
    """u in (0, 1) of shape (n, dimensions): per trial from its seed (random), or a Latin hypercube / the first n
    points of a scrambled Sobol sequence of 2**ceil(log2 n) points (seeded by ``seed``)."""
    n = len(seeds)
    if method == "random":
        return np.array([np.random.default_rng(s).random(dimensions) for s in seeds]).reshape(n, dimensions)
    from scipy.stats import qmc

    rng = np.random.default_rng(np.random.SeedSequence(seed))
    if method == "lhs":
        return qmc.LatinHypercube(dimensions, rng=rng).random(n)
    if method == "sobol":
        return qmc.Sobol(dimensions, scramble=True, rng=rng).random_base2(max(0, math.ceil(math.log2(n))))[:n]
    raise StudyError(f"study method {method!r} is not valid; valid: {', '.join(METHODS)}")


def sample_table(samples: Sequence[tuple[str, Distribution]], n: int, seed: int,
                 method: str = "random") -> tuple[list[int], list[list[Any]]]:
    """The trials' seeds and sampled values: (seeds (n,), values (n, len(samples)))."""
    seeds = trial_seeds(seed, n)
    u = quantiles(method, seeds, seed, len(samples))
    columns = [distribution.ppf(u[:, j]) for j, (_, distribution) in enumerate(samples)]
    return seeds, [list(row) for row in zip(*columns)] if columns else [[] for _ in seeds]


__all__ = ["Distribution", "FORMS", "METHODS", "key_bounds", "parse_sample", "parse_samples", "sample_table",
           "trial_seeds"]
