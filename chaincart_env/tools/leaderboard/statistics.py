"""Statistics over training seeds, as rliable (Agarwal et al., NeurIPS 2021) defines them.

Scores are arrays of shape ``(runs, tasks)``: one row per run (in the leaderboard, a
seed: the training seed of a learned agent and the block of seeded evaluation starts of
every controller) and one column per task (a scene at one value of a robustness axis). All intervals are percentile intervals of a **stratified
bootstrap**: each resample draws, for every task independently, as many runs as there
are with replacement, so every task keeps its weight.

* :func:`interquartile_mean`: the mean of the middle 50 % of all scores (25 % trimmed at
  each end), robust to a few outlying seeds and less noisy than the median.
* :func:`probability_of_improvement`: ``P(X > Y)`` per task (ties count one half), the
  Mann-Whitney statistic divided by ``m n``, averaged over tasks.
* :func:`performance_profile`: the fraction of all scores above each threshold ``tau``.

The definitions follow rliable's ``metrics.aggregate_iqm``,
``metrics.probability_of_improvement`` and ``library.create_performance_profile``; the
package itself is not used because its bootstrap dependency does not import with the
pandas release our other dependencies bring.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from chaincart_env.errors import InvalidInputError

__all__ = [
    "Estimate",
    "interquartile_mean",
    "iqm_estimate",
    "performance_profile",
    "probability_of_improvement",
    "probability_of_improvement_estimate",
    "stratified_bootstrap",
]

#: Bootstrap resamples per interval (rliable's default for aggregates is 50 000; 2 000
#: keeps a leaderboard of many cells quick while the 95 % bounds move by < 0.01).
DEFAULT_RESAMPLES = 2_000


@dataclass(frozen=True)
class Estimate:
    """A point estimate and its 95 % stratified-bootstrap interval."""

    value: float
    low: float
    high: float

    def describe(self, digits: int = 2) -> str:
        """``value [low, high]``."""
        return f"{self.value:.{digits}f} [{self.low:.{digits}f}, {self.high:.{digits}f}]"


def _scores(scores: np.ndarray | Sequence[Sequence[float]], name: str = "scores") -> np.ndarray:
    data = np.asarray(scores, dtype=np.float64)
    if data.ndim == 1:
        data = data[:, None]
    if data.ndim != 2 or data.shape[0] < 1 or data.shape[1] < 1:
        raise InvalidInputError(f"{name} has shape {np.shape(scores)}: expected (runs, tasks) with both >= 1")
    if not np.all(np.isfinite(data)):
        raise InvalidInputError(f"{name} has non-finite entries: expected finite scores")
    return data


def interquartile_mean(scores: np.ndarray | Sequence[Sequence[float]]) -> float:
    """The mean of the middle 50 % of all scores, pooled over runs and tasks."""
    from scipy.stats import trim_mean

    return float(trim_mean(_scores(scores), proportiontocut=0.25, axis=None))


def _resample(data: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """One stratified resample: runs drawn with replacement within every task."""
    runs, tasks = data.shape
    return data[rng.integers(0, runs, size=(runs, tasks)), np.arange(tasks)[None, :]]


def stratified_bootstrap(
    statistic: Callable[..., float | np.ndarray],
    *samples: np.ndarray,
    resamples: int = DEFAULT_RESAMPLES,
    confidence: float = 0.95,
    seed: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """Percentile interval ``(low, high)`` of ``statistic(*samples)``, each sample of
    shape ``(runs, tasks)`` resampled independently and stratified by task."""
    if isinstance(resamples, bool) or int(resamples) != resamples or resamples < 1:
        raise InvalidInputError(f"resamples = {resamples!r}: expected an integer >= 1")
    if not 0.0 < confidence < 1.0:
        raise InvalidInputError(f"confidence = {confidence!r}: expected a number in (0, 1)")
    rng = np.random.default_rng(seed)
    values = np.asarray([statistic(*(_resample(s, rng) for s in samples)) for _ in range(int(resamples))])
    tail = 100.0 * (1.0 - confidence) / 2.0
    low, high = np.percentile(values, [tail, 100.0 - tail], axis=0)
    return np.asarray(low), np.asarray(high)


def iqm_estimate(scores: np.ndarray | Sequence[Sequence[float]], **bootstrap: int | float) -> Estimate:
    """The interquartile mean with its 95 % stratified-bootstrap interval."""
    data = _scores(scores)
    low, high = stratified_bootstrap(interquartile_mean, data, **bootstrap)  # type: ignore[arg-type]
    return Estimate(interquartile_mean(data), float(low), float(high))


def probability_of_improvement(scores_x: np.ndarray, scores_y: np.ndarray) -> float:
    """``P(X > Y) + P(X = Y) / 2`` per task, averaged over tasks: the chance that a run
    of X beats a run of Y on the same task."""
    x, y = _scores(scores_x, "scores_x"), _scores(scores_y, "scores_y")
    if x.shape[1] != y.shape[1]:
        raise InvalidInputError(f"scores_x has {x.shape[1]} tasks and scores_y {y.shape[1]}: expected the same tasks")
    greater = (x[:, None, :] > y[None, :, :]).mean(axis=(0, 1))
    equal = (x[:, None, :] == y[None, :, :]).mean(axis=(0, 1))
    return float(np.mean(greater + 0.5 * equal))


def probability_of_improvement_estimate(
    scores_x: np.ndarray, scores_y: np.ndarray, **bootstrap: int | float
) -> Estimate:
    """:func:`probability_of_improvement` with its 95 % interval (X and Y resampled
    independently, each stratified by task)."""
    x, y = _scores(scores_x, "scores_x"), _scores(scores_y, "scores_y")
    value = probability_of_improvement(x, y)
    low, high = stratified_bootstrap(probability_of_improvement, x, y, **bootstrap)  # type: ignore[arg-type]
    return Estimate(value, float(low), float(high))


def performance_profile(
    scores: np.ndarray | Sequence[Sequence[float]], thresholds: np.ndarray | Sequence[float], **bootstrap: int | float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The fraction of all scores above each threshold, with 95 % bands:
    ``(profile, low, high)``, each of the thresholds' length."""
    data = _scores(scores)
    taus = np.asarray(thresholds, dtype=np.float64)

    def profile(sample: np.ndarray) -> np.ndarray:
        return (sample[..., None] > taus).mean(axis=(0, 1))

    low, high = stratified_bootstrap(profile, data, **bootstrap)  # type: ignore[arg-type]
    return profile(data), low, high
