"""The main job's report says what it found: a verdict from the success rates and
their intervals (an independent count of who is ahead where) against the best
model-based controller, and pictures in which every controller has its own colour,
line style and marker, the same in the main job's and in the leaderboard's pictures,
and a curve hidden under another is named in the legend."""

from __future__ import annotations

import itertools
import pathlib

import numpy as np
import pytest
from matplotlib.figure import Figure

from chaincart_env.tools.compare.plots import draw_sweep
from chaincart_env.tools.compare.styles import LOOKS, policy_style
from chaincart_env.tools.controllers import CONTROLLERS, label_of
from chaincart_env.tools.compare.verdict import Rate, compare_rates, main_starts_rate, verdict_lines

POLICIES = ["PPO", "PPO best", "LQR", "LQR oracle"]


def sweep_rows(rates: dict[str, list[tuple[float, float, float]]], values: list[float]) -> list[dict]:
    return [
        dict(value=v, policy=p, success_rate=r, ci_low=lo, ci_high=hi)
        for p, per_value in rates.items() for v, (r, lo, hi) in zip(values, per_value)
    ]  # fmt: skip


@pytest.mark.parametrize(
    "agent, baseline, expected",
    [
        (Rate(0.9, 0.8, 0.95), Rate(0.5, 0.4, 0.6), "agent"),
        (Rate(0.2, 0.1, 0.3), Rate(0.7, 0.6, 0.8), "baseline"),
        (Rate(0.0, 0.0, 0.56), Rate(1.0, 0.44, 1.0), "tie"),  # 0/3 against 3/3: the intervals overlap
        (Rate(1.0, 0.96, 1.0), Rate(1.0, 0.96, 1.0), "tie"),
    ],
)
def test_a_side_is_ahead_only_when_its_interval_lies_above_the_other(agent: Rate, baseline: Rate, expected: str) -> None:
    assert compare_rates(agent, baseline) == expected


def test_the_main_starts_rate_is_wilson_over_episodes_for_one_seed_and_bootstrap_for_several() -> None:
    one = main_starts_rate(dict(success_rate=0.5, episodes=20), dict(seeds=1, success_ci_low=float("nan")))
    assert one.value == 0.5 and one.low == pytest.approx(0.2993, abs=1e-4) and one.high == pytest.approx(0.7007, abs=1e-4)
    several = dict(seeds=3, success_mean=0.6, success_ci_low=0.4, success_ci_high=0.8)
    assert main_starts_rate(dict(success_rate=0.5, episodes=20), several) == Rate(0.6, 0.4, 0.8)


def test_the_verdict_names_who_is_ahead_where() -> None:
    values = [0.05, 0.3, 0.5]
    starts = {
        "PPO": [(1.0, 0.96, 1.0), (0.4, 0.3, 0.5), (0.1, 0.05, 0.2)],
        "LQR": [(1.0, 0.96, 1.0), (0.7, 0.6, 0.8), (0.15, 0.1, 0.25)],
    }
    mismatch = {"PPO": [(0.9, 0.8, 0.95), (0.7, 0.6, 0.8)], "LQR": [(1.0, 0.96, 1.0), (0.3, 0.2, 0.4)]}
    lines = verdict_lines(
        agent="PPO", seeds=1, baseline="LQR", episodes=100,
        main=(Rate(1.0, 0.96, 1.0), Rate(1.0, 0.96, 1.0)), returns=(95.5, 97.0),
        sweeps={"start_noise": ("start perturbation", sweep_rows(starts, values)),
                "mismatch": ("model mismatch", sweep_rows(mismatch, [0.0, 0.4]))},
    )  # fmt: skip
    text = "\n".join(lines)
    # 6 settings: the starts (tie), start noise (tie, LQR, tie), mismatch (LQR, PPO).
    assert lines[0].startswith("**each side is ahead somewhere: PPO and LQR split**")
    assert "success rates at 6 setting(s): PPO ahead at 1, LQR ahead at 2, tied at 3." in lines[0]
    assert "* On the 100 evaluation starts: PPO succeeded in 100% [0.96, 1.00] of episodes, LQR in 100% [0.96, 1.00]: tied; mean return 95.5 against 97.0." in text
    assert "* start perturbation: LQR ahead at 0.3; tied at 0.05, 0.5 (higher rate within the intervals: LQR at 0.5)." in text
    assert "* model mismatch: PPO ahead at 0.4; LQR ahead at 0." in text
    assert "With one training seed the intervals are over episodes only" in text


def test_a_one_sided_verdict_says_who_succeeded_more_often() -> None:
    rows = sweep_rows({"PPO": [(0.2, 0.1, 0.3)], "LQR": [(0.8, 0.7, 0.9)]}, [0.3])
    lines = verdict_lines(agent="PPO", seeds=3, baseline="LQR", episodes=50, main=(Rate(1, 0.9, 1), Rate(1, 0.9, 1)),
                          returns=(1.0, 1.0), sweeps={"start_noise": ("start perturbation", rows)})  # fmt: skip
    assert lines[0].startswith("**LQR succeeded more often than PPO**: PPO (3 training seeds)")
    assert "Intervals of the agent: bootstrap over seeds" in lines[-1]


def test_every_controller_and_variant_has_a_look_of_its_own() -> None:
    assert {name for name, _ in LOOKS} == set(CONTROLLERS)
    for (a_key, a), (b_key, b) in itertools.combinations(LOOKS.items(), 2):
        differ = (a.color != b.color, str(a.linestyle) != str(b.linestyle), a.marker != b.marker, a.hatch != b.hatch)
        assert all(differ), (a_key, b_key, differ)


def test_a_controller_has_one_look_whatever_names_it() -> None:
    # The leaderboard's names, the main job's labels, a seed's row, the RLlib trainer's label.
    assert policy_style("PPO (seed 4)") == policy_style("PPO") == policy_style("ppo") == policy_style("PPO (RLlib)")
    assert policy_style("lqr") == policy_style("LQR") == LOOKS[("lqr", "")]
    assert policy_style("SAC best (seed 1)") == LOOKS[("sac", "best")] != policy_style("PPO best")
    assert policy_style("LQR oracle") == LOOKS[("lqr", "oracle")]
    for name in CONTROLLERS:
        assert policy_style(name) == policy_style(label_of(name)) == LOOKS[(name, "")]
    assert policy_style("zero") not in LOOKS.values()  # no controller: a look of its own


def test_the_main_job_and_the_leaderboard_draw_a_controller_alike(
    tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from chaincart_env.tools.leaderboard import report as leaderboard_report
    from chaincart_env.tools.leaderboard.axes import parse_axes

    names = ["ppo", "sac", "lqr", "mpc"]
    rates = {label_of(n): [(0.8 - k / 10, 0.5, 0.9), (0.2, 0.1, 0.4)] for k, n in enumerate(names)}
    ax = Figure().subplots()
    draw_sweep(ax, sweep_rows(rates, [0.0, 0.3]), "model mismatch")
    in_main_job = {line.get_label(): line for line in ax.get_lines()}
    drawn: list[Figure] = []
    monkeypatch.setattr(Figure, "savefig", lambda fig, *args, **kwargs: drawn.append(fig))
    cells = [dict(scene="s", controller=n, axis="mismatch", value=v, seed=0, episodes=4, successes=w, success_rate=w / 4)
             for n in names for v, w in ((0.0, 3), (0.3, 1))]  # fmt: skip
    leaderboard_report._plot_scene(tmp_path / "s.png", cells, parse_axes("mismatch"), "s")
    in_leaderboard = {line.get_label(): line for line in drawn[0].axes[0].get_lines()}
    for name in names:
        ours, theirs = in_main_job[label_of(name)], in_leaderboard[name]
        for look in ("get_color", "get_linestyle", "get_marker"):
            assert getattr(ours, look)() == getattr(theirs, look)(), (name, look)
    hatches = {c.get_hatch() for c in drawn[0].axes[0].collections if c.get_hatch()}
    assert hatches == {LOOKS[(n, "")].hatch for n in names}


def test_the_sweep_plot_keeps_coinciding_policies_apart_and_names_the_hidden_ones() -> None:
    values = [0.1, 0.3]
    same_lqr = [(1.0, 0.9, 1.0), (0.5, 0.3, 0.7)]
    rows = sweep_rows({"PPO": [(0.8, 0.6, 0.9), (0.2, 0.1, 0.4)], "PPO best": [(0.9, 0.7, 1.0), (0.3, 0.1, 0.5)],
                       "LQR": same_lqr, "LQR oracle": same_lqr}, values)  # fmt: skip
    ax = Figure().subplots()
    draw_sweep(ax, rows, "start perturbation")
    lines = ax.get_lines()
    assert [line.get_label() for line in lines] == [
        "PPO", "PPO best", "LQR", "LQR oracle (same as LQR: lines coincide)",
    ]
    assert len({line.get_color() for line in lines}) == 4 and len({str(line.get_linestyle()) for line in lines}) == 4
    hatched = [c for c in ax.collections if c.get_hatch()]
    assert len(hatched) == 4 and len({c.get_hatch() for c in hatched}) == 4
    band_colors = {tuple(np.round(c.get_edgecolor()[0][:3], 3)) for c in hatched}
    assert len(band_colors) == 4  # no single colour for every band
