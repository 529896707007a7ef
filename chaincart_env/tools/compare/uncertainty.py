"""Uncertainty of the main job's numbers.

* A success rate over ``n`` seeded episodes gets its 95% **Wilson score interval**
  (``scipy.stats.binomtest(...).proportion_ci(method="wilson")``): it stays inside
  [0, 1] and is honest at 0/n and n/n, where the normal approximation collapses.
* A metric measured once per **training seed** (an agent's success rate, its mean
  return, ...) is aggregated as the mean over seeds with a 95% **percentile bootstrap
  interval** over seeds (``scipy.stats.bootstrap``, resampling seeds with replacement,
  a fixed random state so reports reproduce). With one seed there is no interval
  (NaN): the spread between agents is then unknown, and the report says so.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from chaincart_env.errors import InvalidInputError

__all__ = ["BOOTSTRAP_RESAMPLES", "SeedAggregate", "aggregate_over_seeds", "wilson_interval"]

#: Bootstrap resamples per interval: enough for a stable 95% percentile interval.
BOOTSTRAP_RESAMPLES = 9_999


def wilson_interval(successes: int, trials: int, confidence: float = 0.95) -> tuple[float, float]:
    """The Wilson score interval of ``successes`` out of ``trials``."""
    from scipy.stats import binomtest

    if isinstance(trials, bool) or int(trials) != trials or trials < 1:
        raise InvalidInputError(f"trials = {trials!r}: expected an integer >= 1")
    if isinstance(successes, bool) or int(successes) != successes or not 0 <= successes <= trials:
        raise InvalidInputError(f"successes = {successes!r}: expected an integer in [0, trials = {trials}]")
    interval = binomtest(int(successes), int(trials)).proportion_ci(confidence_level=confidence, method="wilson")
    return float(interval.low), float(interval.high)


@dataclass(frozen=True)
class SeedAggregate:
    """A metric over training seeds: the mean and its 95% bootstrap interval."""

    mean: float
    ci_low: float
    ci_high: float
    seeds: int

    def describe(self, digits: int = 3) -> str:
        """``mean [low, high]``, or ``mean (1 seed)`` when there is no interval."""
        if self.seeds < 2 or not math.isfinite(self.ci_low):
            return f"{self.mean:.{digits}g} ({self.seeds} seed{'s' if self.seeds != 1 else ''})"
        return f"{self.mean:.{digits}g} [{self.ci_low:.{digits}g}, {self.ci_high:.{digits}g}]"


def aggregate_over_seeds(values: Sequence[float], random_state: int = 0) -> SeedAggregate:
    """Mean of one number per training seed, with its 95% percentile bootstrap interval
    over seeds (NaN bounds for one seed, or when every seed gave the same number the
    interval is that number)."""
    from scipy.stats import bootstrap

    data = np.asarray(values, dtype=np.float64)
    if data.ndim != 1 or data.size == 0:
        raise InvalidInputError(f"values = {values!r}: expected one number per seed, at least one")
    if not np.all(np.isfinite(data)):
        raise InvalidInputError(f"values = {values!r}: expected finite numbers")
    mean = float(data.mean())
    if data.size == 1:
        return SeedAggregate(mean, float("nan"), float("nan"), 1)
    if np.all(data == data[0]):
        return SeedAggregate(mean, mean, mean, int(data.size))
    result = bootstrap(
        (data,), np.mean, confidence_level=0.95, n_resamples=BOOTSTRAP_RESAMPLES, method="percentile",
        rng=np.random.default_rng(random_state),
    )
    interval = result.confidence_interval
    return SeedAggregate(mean, float(interval.low), float(interval.high), int(data.size))
