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

from chaincart_env.tools.compare.study_plots import draw_sweep
from chaincart_env.tools.compare.styles import LOOKS, policy_style
from chaincart_env.tools.compare.verdict import Rate, compare_rates, main_starts_rate, verdict_lines
from chaincart_env.tools.controllers import CONTROLLERS, label_of

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
    assert "success rates at 6 distinct settings: PPO ahead at 1, LQR ahead at 2, tied at 3." in lines[0]
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
    from chaincart_env.tools.leaderboard import leaderboard_report
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


# -- what the report says once -------------------------------------------------------

from types import SimpleNamespace  # noqa: E402

from chaincart_env.config import ChainCartConfig  # noqa: E402
from chaincart_env.tools.compare.filmstrip import filmstrip, frame_steps  # noqa: E402
from chaincart_env.tools.compare.study_plots import draw_errors  # noqa: E402
from chaincart_env.tools.compare.study_report import seed_lines, sweep_markdown, write_report  # noqa: E402
from chaincart_env.tools.compare.tables import markdown_table, variant_base  # noqa: E402
from chaincart_env.tools.compare.verdict import main_setting_values  # noqa: E402


def test_a_sweep_value_that_is_the_evaluation_starts_setting_is_counted_once() -> None:
    """The default study: the starts (the scene's start perturbation 0.05, no mismatch),
    start perturbations 0.05 .. 0.5 and mismatch 0, 0.2, 0.4: nine measurements, seven
    distinct settings."""
    config = ChainCartConfig()
    sweeps_values = {"start_noise": [0.05, 0.1, 0.2, 0.3, 0.5], "mismatch": [0.0, 0.2, 0.4]}
    nominal = main_setting_values(config, sweeps_values)
    assert nominal == {"start_noise": [0.05], "mismatch": [0.0]}
    tie, lqr = (1.0, 0.9, 1.0), (0.9, 0.8, 0.95)
    rows = {"PPO": [tie, tie, tie, tie, tie], "LQR": [tie, tie, lqr, lqr, lqr]}
    lines = verdict_lines(
        agent="PPO", seeds=1, baseline="LQR", episodes=20, main=(Rate(1.0, 0.9, 1.0), Rate(1.0, 0.9, 1.0)),
        returns=(90.0, 91.0),
        sweeps={"start_noise": ("start perturbation", sweep_rows(rows, sweeps_values["start_noise"])),
                "mismatch": ("model mismatch", sweep_rows({p: r[:3] for p, r in rows.items()}, [0.0, 0.2, 0.4]))},
        nominal=nominal,
    )  # fmt: skip
    assert "success rates at 7 distinct settings: PPO ahead at 0, LQR ahead at 0, tied at 7." in lines[0], lines[0]
    assert "tied at 0.05 (the evaluation starts' setting), 0.1, 0.2, 0.3, 0.5" in "\n".join(lines)
    assert "tied at 0 (the evaluation starts' setting), 0.2, 0.4" in "\n".join(lines)


def _summary(policy: str, success: float, ret: float) -> dict:
    return dict(policy=policy, episodes=20, return_mean=ret, return_std=1.0, success_rate=success,
                final_e_q_mean=1e-3, final_e_q_std=1e-4, final_e_w_mean=1e-3, final_e_w_std=1e-4,
                peak_force_mean=5.0, peak_force_std=1.0, rms_force_mean=1.0, rms_force_std=0.1,
                settle_time_mean=float("nan"), settle_time_std=float("nan"), settled=0)  # fmt: skip


def _table_policies(text: str) -> list[str]:
    return [line.split("|")[1].strip() for line in text.splitlines() if line.startswith("| ") and "---" not in line][1:]


def test_a_variant_row_is_shown_only_where_it_differs_from_its_policy() -> None:
    assert variant_base("PPO best") == "PPO" and variant_base("PPO best (seed 3)") == "PPO (seed 3)"
    assert variant_base("LQR oracle") == "LQR" and variant_base("PPO") is None
    same = markdown_table([_summary("PPO", 0.9, 80.0), _summary("PPO best", 0.9, 80.0), _summary("LQR", 1.0, 90.0),
                           _summary("LQR oracle", 1.0, 90.0)])  # fmt: skip
    assert _table_policies(same) == ["PPO", "LQR"]
    assert ("PPO best has no rows of its own: its numbers are PPO's wherever it was measured (the best model by "
            "evaluation is the final one).") in same
    assert "LQR oracle has no rows of its own: its numbers are LQR's wherever it was measured (the true system is the model)." in same
    differ = markdown_table([_summary("PPO", 0.9, 80.0), _summary("PPO best", 0.95, 85.0)])
    assert _table_policies(differ) == ["PPO", "PPO best"] and "no rows" not in differ


def _sweep_row(value: float, policy: str, rate: float) -> dict:
    return dict(axis="mismatch", value=value, policy=policy, seeds=1, episodes=20, success_rate=rate, ci_low=rate - 0.1,
                ci_high=min(1.0, rate + 0.1), interval="Wilson, over episodes", return_mean=50 * rate,
                settle_time_mean=1.0, peak_force_mean=5.0)  # fmt: skip


def test_the_oracle_has_a_sweep_row_only_where_the_true_system_differs_from_the_model() -> None:
    rows = [_sweep_row(v, p, r) for v, p, r in [
        (0.0, "LQR", 1.0), (0.0, "LQR oracle", 1.0), (0.4, "LQR", 0.5), (0.4, "LQR oracle", 0.8),
        (0.0, "PPO", 0.9), (0.0, "PPO best", 0.9), (0.4, "PPO", 0.3), (0.4, "PPO best", 0.3),
    ]]  # fmt: skip
    text = sweep_markdown(rows, "model mismatch")
    table = [line for line in text.splitlines() if line.startswith("| 0")]
    assert [tuple(c.strip() for c in line.split("|")[1:3]) for line in table] == [
        ("0", "LQR"), ("0", "PPO"), ("0.4", "LQR"), ("0.4", "LQR oracle"), ("0.4", "PPO"),
    ]
    assert text.count("PPO best has no rows of its own: its numbers are PPO's") == 1
    assert "LQR oracle has rows only where its numbers differ from LQR's; elsewhere they are the same (the true system is the model)." in text
    assert "PPO best:" not in text  # nor in the intervals


def test_one_seed_s_missing_interval_is_said_once_and_the_best_model_line_only_when_it_differs() -> None:
    row = dict(policy="PPO", seeds=1, success_mean=0.9, return_mean=80.0, success_ci_low=float("nan"),
               success_ci_high=float("nan"), return_ci_low=float("nan"), return_ci_high=float("nan"))  # fmt: skip
    lines = seed_lines([row, {**row, "policy": "PPO best"}, {**row, "policy": "SAC", "success_mean": 0.5}])
    text = "\n".join(lines)
    assert lines[-1] == "One seed gives no interval over seeds (train several with --seeds)."
    assert text.count("One seed gives no interval over seeds") == 1
    assert text.count("PPO, one training seed") == 1 and "PPO best, one training seed" not in text
    assert "SAC, one training seed: success 0.50" in text
    differ = seed_lines([row, {**row, "policy": "PPO best", "success_mean": 1.0}])
    assert sum("one training seed" in line for line in differ) == 2


def _errors_run(policy: str, e_q: np.ndarray, dt: float = 0.02) -> SimpleNamespace:
    return SimpleNamespace(policy=policy, dt=dt, e_q=e_q[None, :], lengths=np.array([e_q.size - 1]), seeds=np.array([0]))


def test_the_tolerance_line_lies_inside_the_error_panel_and_the_first_policy_on_top() -> None:
    t = np.arange(200) * 0.02
    # Both start below the tolerance and settle to the same floor at the end.
    ppo = np.maximum(0.08 * np.exp(-3 * t), 1e-9)
    lqr = np.maximum(0.06 * np.exp(-4 * t), 1e-9)
    ax = Figure().subplots()
    draw_errors(ax, [_errors_run("PPO", ppo), _errors_run("LQR", lqr)], "e_q", 0.1)
    low, high = ax.get_ylim()
    assert low < 1e-8 / 2 and high > 0.1 * 2, (low, high)
    lines = {line.get_label(): line for line in ax.get_lines()}
    assert lines["PPO"].get_zorder() > lines["LQR"].get_zorder()
    assert lines["PPO"].get_linewidth() < lines["LQR"].get_linewidth()


def _lqr_rollout(config: ChainCartConfig, seed: int) -> object:
    """A real LQR episode of ``config``: on the default scene a short transient, then stillness."""
    from chaincart_env import ChainCartEnv, LQRPolicy
    from chaincart_env.tools.compare.evaluation import rollout

    return rollout(LQRPolicy.from_env(ChainCartEnv(config)), "LQR", config, [seed])


def test_the_filmstrip_shows_the_part_of_the_episode_where_the_chain_moves() -> None:
    config = ChainCartConfig()
    run = _lqr_rollout(config, seed=0)
    assert run.success[0] and run.lengths[0] == config.max_episode_steps
    steps = frame_steps([run], 6)
    # The chain moves in the first two seconds (e_q peaks there), then settles slowly.
    assert steps[0] == 0 and np.sum(steps * config.dt < 2.0) >= 4, steps
    assert np.argmax(run.e_q[0]) * config.dt < 2.0 and run.e_q[0, steps[-1]] < 0.2 * run.e_q[0].max()
    image = filmstrip([run], config, 6)
    width = image.shape[1] // 6
    frames = [image[:, k * width:(k + 1) * width] for k in range(6)]
    assert all(not np.array_equal(a, b) for a, b in itertools.combinations(frames, 2))


def test_the_filmstrip_of_a_swing_up_shows_the_swing_not_the_hold() -> None:
    from chaincart_env import ChainCartEnv
    from chaincart_env.policies import TrajectoryPolicy
    from chaincart_env.tools.compare.evaluation import rollout

    config = ChainCartConfig(scene="swingup-2")
    run = rollout(TrajectoryPolicy.from_env(ChainCartEnv(config)), "trajectory", config, [0])
    assert run.success[0]
    steps = frame_steps([run], 6)
    # From hanging (e_q = 4) to nearly upright, and not the second half's holding still.
    assert run.e_q[0, 0] > 3.5 and run.e_q[0, steps[-1]] < 0.2 and steps[-1] < run.lengths[0] // 2, steps
    assert all(run.e_q[0, k] > 1.0 for k in steps[:-1]), run.e_q[0, steps]


def test_the_report_says_each_sentence_once(tmp_path: pathlib.Path) -> None:
    """The default study's report, made of one-seed PPO whose best model is its final one
    and an oracle LQR that equals the LQR except under mismatch: each left-out row is
    explained once, and the one-seed caveat is said once."""
    comparison = [_summary("PPO (seed 0)", 1.0, 498.0), _summary("PPO best (seed 0)", 1.0, 498.0),
                  _summary("LQR", 1.0, 497.0), _summary("LQR oracle", 1.0, 497.0)]  # fmt: skip
    start = [_sweep_row(v, p, r) for v in (0.05, 0.1) for p, r in (("PPO", 1.0), ("PPO best", 1.0), ("LQR", 1.0),
                                                                    ("LQR oracle", 1.0))]  # fmt: skip
    mismatch = [_sweep_row(v, p, r) for v, p, r in [
        (0.0, "PPO", 1.0), (0.0, "PPO best", 1.0), (0.0, "LQR", 1.0), (0.0, "LQR oracle", 1.0),
        (0.4, "PPO", 0.7), (0.4, "PPO best", 0.7), (0.4, "LQR", 0.9), (0.4, "LQR oracle", 1.0),
    ]]  # fmt: skip
    seed_row = dict(policy="PPO", seeds=1, success_mean=1.0, return_mean=498.0)
    text = write_report(
        tmp_path, title="t", verdict=["v"], setup=["scene"] + seed_lines([seed_row, {**seed_row, "policy": "PPO best"}]),
        comparison=comparison, sweeps={"start_noise": ("start", start), "mismatch": ("mismatch", mismatch)},
        training=[], pictures=[],
    )  # fmt: skip
    assert text.count("One seed gives no interval over seeds") == 1
    assert text.count("PPO best has no rows of its own: its numbers are PPO's wherever it was measured") == 1
    assert text.count("LQR oracle has rows only where its numbers differ from LQR's") == 1
    assert "| PPO best" not in text and text.count("| LQR oracle |") == 1 and "PPO best, one training seed" not in text
