"""The leaderboard's statistics against cases worked by hand and against SciPy's
Mann-Whitney statistic (the definitions rliable uses)."""

from __future__ import annotations

import numpy as np
import pytest

from chaincart_env.errors import InvalidInputError
from chaincart_env.tools.leaderboard.statistics import (
    interquartile_mean,
    iqm_estimate,
    performance_profile,
    probability_of_improvement,
    probability_of_improvement_estimate,
    stratified_bootstrap,
)


def test_interquartile_mean_trims_a_quarter_at_each_end_of_all_scores():
    # Sorted: 0, 0, 0.2, 0.5, 0.5, 0.8, 1, 1; the middle four average to 0.5.
    scores = np.array([[0.0, 1.0], [0.5, 0.5], [1.0, 0.0], [0.2, 0.8]])
    assert interquartile_mean(scores) == pytest.approx(0.5, abs=1e-15)
    # An outlier in the top quarter does not move it.
    scores[0, 1] = 100.0
    assert interquartile_mean(scores) == pytest.approx(0.5, abs=1e-15)


def test_probability_of_improvement_counts_ties_as_half_and_averages_tasks():
    # Task 1: X always beats Y (1). Task 2: X = (0, 0), Y = (0, 1): no win, two ties of
    # four pairs: 0.5 * 2 / 4 = 0.25. Mean over tasks: 0.625.
    x = np.array([[1.0, 0.0], [1.0, 0.0]])
    y = np.array([[0.0, 0.0], [0.0, 1.0]])
    assert probability_of_improvement(x, y) == pytest.approx(0.625)
    assert probability_of_improvement(y, x) == pytest.approx(0.375)
    assert probability_of_improvement(x, x) == pytest.approx(0.5)


def test_probability_of_improvement_is_the_mann_whitney_statistic_over_mn():
    from scipy.stats import mannwhitneyu

    rng = np.random.default_rng(7)
    x = rng.integers(0, 5, size=(6, 3)) / 4.0  # coarse scores: many ties
    y = rng.integers(0, 5, size=(4, 3)) / 4.0
    expected = np.mean([mannwhitneyu(x[:, t], y[:, t], alternative="greater").statistic / 24 for t in range(3)])
    assert probability_of_improvement(x, y) == pytest.approx(expected, abs=1e-12)


def test_stratified_bootstrap_resamples_runs_within_each_task():
    # Task 1 always scores 0 and task 2 always 1 (with varied runs inside each task):
    # a resample that kept the tasks apart always has mean 0.5; one that mixed tasks
    # would not.
    scores = np.array([[0.0, 1.0], [0.0, 1.0], [0.0, 1.0]])
    low, high = stratified_bootstrap(np.mean, scores, resamples=500, seed=3)
    assert float(low) == float(high) == 0.5
    varied = np.array([[0.0, 1.0], [0.2, 0.8], [0.4, 0.6]])
    low, high = stratified_bootstrap(lambda s: s[:, 0].max(), varied, resamples=500, seed=3)
    assert 0.0 <= float(low) <= float(high) <= 0.4  # task 1's runs only


def test_intervals_bracket_the_estimate_and_repeat_under_a_seed():
    rng = np.random.default_rng(0)
    scores = rng.random((10, 4))
    first = iqm_estimate(scores, resamples=400, seed=11)
    assert first.low <= first.value <= first.high
    assert first == iqm_estimate(scores, resamples=400, seed=11)
    poi = probability_of_improvement_estimate(scores + 1.0, scores, resamples=400, seed=1)
    assert poi.value == pytest.approx(1.0) and poi.low == pytest.approx(1.0)


def test_performance_profile_is_the_fraction_above_each_threshold():
    scores = np.array([[0.0, 1.0], [0.5, 0.5], [1.0, 0.0], [0.2, 0.8]])
    profile, low, high = performance_profile(scores, [-0.1, 0.0, 0.5, 0.9, 1.0], resamples=300)
    np.testing.assert_allclose(profile, [1.0, 6 / 8, 3 / 8, 2 / 8, 0.0])
    assert np.all(low <= profile) and np.all(profile <= high)


@pytest.mark.parametrize(
    "bad, message",
    [
        (np.zeros((0, 2)), "expected (runs, tasks)"),
        (np.array([[0.0, np.nan]]), "non-finite"),
        (np.zeros((2, 2, 2)), "expected (runs, tasks)"),
    ],
)
def test_bad_scores_are_refused_with_their_shape_or_values(bad, message):
    with pytest.raises(InvalidInputError, match=message.replace("(", r"\(").replace(")", r"\)")):
        interquartile_mean(bad)


def test_mismatched_tasks_and_bad_bootstrap_settings_are_refused():
    with pytest.raises(InvalidInputError, match="same tasks"):
        probability_of_improvement(np.zeros((2, 2)), np.zeros((2, 3)))
    with pytest.raises(InvalidInputError, match="resamples = 0"):
        iqm_estimate(np.zeros((2, 2)), resamples=0)
    with pytest.raises(InvalidInputError, match="confidence = 1.5"):
        iqm_estimate(np.zeros((2, 2)), confidence=1.5)


def test_three_seeds_give_an_interval_close_to_the_exact_bootstrap_one():
    from itertools import product

    # One task, three seeds: the exact bootstrap distribution of the IQM is that of the
    # 27 equally likely resamples (the IQM of three scores trims nothing: their mean).
    seeds = np.array([[0.2], [0.5], [0.9]])
    exact = np.array([np.mean(draw) for draw in product(seeds[:, 0], repeat=3)])
    estimate = iqm_estimate(seeds, resamples=4000, seed=1)
    assert estimate.value == pytest.approx(np.mean(seeds))
    # The distribution's own quantiles (27 equally likely values: no interpolation).
    assert estimate.low == pytest.approx(np.quantile(exact, 0.025, method="inverted_cdf"), abs=0.04)
    assert estimate.high == pytest.approx(np.quantile(exact, 0.975, method="inverted_cdf"), abs=0.04)


def test_a_three_seed_leaderboard_table_shows_intervals_over_seeds():
    from chaincart_env.tools.leaderboard.leaderboard_report import _scene_table, score_rows

    def cell(controller, value, seed, wins):
        return dict(scene="s", controller=controller, axis="mismatch", value=value, seed=seed, episodes=10,
                    successes=wins, success_rate=wins / 10, peak_force_mean=1.0, rms_force_mean=1.0, us_per_step=1.0)

    rows = [cell(c, v, s, w) for c, base in (("a", 9), ("b", 3)) for v in (0.0, 0.3) for s, w in
            zip((0, 1, 2), (base, base - 2, base + 1))]
    scores = score_rows(rows)
    for score in scores:
        assert score["iqm_low"] < score["iqm"] < score["iqm_high"]
    table = _scene_table(rows, scores, ["mismatch"])
    import re

    assert "no interval" not in table and len(re.findall(r"\| \d\.\d\d \[\d\.\d\d, \d\.\d\d\] \|", table)) == 2
