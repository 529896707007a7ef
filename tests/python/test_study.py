"""The main job's study: intervals, aggregation over seeds and sweeps on shared starts."""

from __future__ import annotations

import math

import numpy as np
import pytest

from chaincart_env import ChainCartConfig, ChainCartError, LQRPolicy
from chaincart_env.env import ChainCartEnv
from chaincart_env.roa import success_fractions
from chaincart_env.tools.compare.sweeps import parse_sweep, run_sweep
from chaincart_env.tools.compare.uncertainty import aggregate_over_seeds, wilson_interval


def test_wilson_interval_matches_the_closed_form() -> None:
    z = 1.959963984540054
    for k, n in [(8, 10), (0, 10), (10, 10), (37, 50)]:
        p = k / n
        centre = (p + z * z / (2 * n)) / (1 + z * z / n)
        half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
        low, high = wilson_interval(k, n)
        assert low == pytest.approx(max(0.0, centre - half), abs=1e-12)
        assert high == pytest.approx(min(1.0, centre + half), abs=1e-12)


@pytest.mark.parametrize("k, n", [(-1, 10), (11, 10), (1, 0), (True, 3), (1.5, 3)])
def test_wilson_interval_rejects_impossible_counts(k: object, n: object) -> None:
    with pytest.raises(ChainCartError):
        wilson_interval(k, n)  # type: ignore[arg-type]


def test_bootstrap_over_two_seeds_has_the_known_percentile_interval() -> None:
    # Resampling {0, 1} with replacement gives a mean of 0, 0.5 or 1 with probabilities
    # 1/4, 1/2, 1/4: the 2.5% and 97.5% percentiles are 0 and 1.
    result = aggregate_over_seeds([0.0, 1.0])
    assert (result.mean, result.ci_low, result.ci_high, result.seeds) == (0.5, 0.0, 1.0, 2)


def test_bootstrap_interval_brackets_the_mean_and_is_reproducible() -> None:
    values = [0.62, 0.9, 0.74, 0.95, 0.81]
    first, again = aggregate_over_seeds(values), aggregate_over_seeds(values)
    assert first == again
    assert min(values) <= first.ci_low < first.mean < first.ci_high <= max(values)
    assert first.mean == pytest.approx(np.mean(values))


def test_one_seed_has_no_interval_and_equal_seeds_a_point() -> None:
    single = aggregate_over_seeds([0.7])
    assert single.mean == 0.7 and math.isnan(single.ci_low) and "1 seed" in single.describe()
    assert aggregate_over_seeds([1.0, 1.0, 1.0]).describe() == "1 [1, 1]"
    with pytest.raises(ChainCartError):
        aggregate_over_seeds([])
    with pytest.raises(ChainCartError):
        aggregate_over_seeds([1.0, float("nan")])


def test_sweep_option_is_parsed_and_checked() -> None:
    assert parse_sweep("start_noise=0.05,0.2") == ("start_noise", [0.05, 0.2])
    assert parse_sweep("mismatch=0,0.3") == ("mismatch", [0.0, 0.3])
    assert parse_sweep("delay=0,1,2") == ("delay", [0.0, 1.0, 2.0])
    assert parse_sweep("obs_noise=0.01") == ("obs_noise", [0.01])
    for bad in ("start_noise", "speed=1", "start_noise=", "start_noise=a", "start_noise=-0.1", "start_noise=inf",
                "mismatch=1.5", "delay=0.5", "obs_noise=-1"):
        with pytest.raises(ChainCartError, match="sweep"):
            parse_sweep(bad)


class _Zero:
    """A policy that never pushes."""

    def predict(self, obs, state=None, episode_start=None, deterministic=False):  # type: ignore[no-untyped-def]
        return np.zeros((len(obs), 1), dtype=np.float32), None


def test_sweep_runs_every_policy_on_the_same_starts_and_agrees_with_roa() -> None:
    config = ChainCartConfig(scene="inverted-1", max_episode_steps=100)
    lqr = LQRPolicy.from_env(ChainCartEnv(config))
    seeds = list(range(20))
    policies = [("LQR", lqr), ("zero", _Zero()), ("LQR again", lqr)]
    rows = run_sweep(policies, config, "start_noise", [0.05, 0.6], seeds)
    assert [(r["value"], r["policy"]) for r in rows] == [
        (v, name) for v in (0.05, 0.6) for name in ("LQR", "zero", "LQR again")
    ]
    # The same starts for every policy: a copy of a policy under another name scores the same.
    for first, copy in ((rows[0], rows[2]), (rows[3], rows[5])):
        assert {k: v for k, v in first.items() if k != "policy"} == {k: v for k, v in copy.items() if k != "policy"}
    assert all(r["episodes"] == 20 and r["ci_low"] <= r["success_rate"] <= r["ci_high"] for r in rows)
    for row in rows:
        if row["policy"] == "LQR":
            roa = success_fractions(config.replace(start_noise=row["value"]), starts=20, seed=0, policy=lqr)
            assert row["success_rate"] == roa.success
    lqr_small, zero_small, lqr_large = rows[0], rows[1], rows[3]
    assert lqr_small["success_rate"] == 1.0 and zero_small["success_rate"] < 1.0
    assert lqr_large["success_rate"] < 1.0  # 0.6 is outside the LQR's region of attraction here


# --- training-time evaluation and checkpoints ---------------------------------------

def _tiny_ppo(seed: int = 0):  # type: ignore[no-untyped-def]
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecMonitor

    from chaincart_env import ChainCartVecEnv

    torch.set_num_threads(1)
    venv = VecMonitor(ChainCartVecEnv(4, ChainCartConfig(scene="inverted-1"), seed=seed))
    return PPO("MlpPolicy", venv, n_steps=32, batch_size=64, n_epochs=2, seed=seed, device="cpu")


def _same_weights(a, b) -> bool:  # type: ignore[no-untyped-def]
    import torch

    wa, wb = a.policy.state_dict(), b.policy.state_dict()
    return wa.keys() == wb.keys() and all(torch.equal(wa[k], wb[k]) for k in wa)


def test_periodic_evaluation_rows_best_model_and_no_effect_on_training(tmp_path) -> None:  # type: ignore[no-untyped-def]
    from chaincart_env.tools.compare.periodic_eval import PeriodicEvaluation, read_evaluations

    config = ChainCartConfig(scene="inverted-1", max_episode_steps=50)
    evaluation = PeriodicEvaluation(config, seeds=[7, 8, 9], every=256, directory=tmp_path)
    with_eval = _tiny_ppo()
    with_eval.learn(640, callback=evaluation)
    rows = read_evaluations(tmp_path / "evaluations.csv")
    # At the start, at the first rollout boundary past 256 and 512, and at the end.
    assert [int(r["timesteps"]) for r in rows] == [0, 256, 512, 640]
    assert all(r["episodes"] == 3 and r["ci_low"] <= r["success_rate"] <= r["ci_high"] for r in rows)
    best = max(rows, key=lambda r: (r["success_rate"], r["return_mean"]))
    assert evaluation.best == best and (tmp_path / "best_model.zip").is_file()
    # The saved best model scores what its row says on the same starts.
    from stable_baselines3 import PPO

    from chaincart_env.tools.compare.evaluation import rollout

    again = rollout(PPO.load(tmp_path / "best_model.zip", device="cpu"), "best", config, [7, 8, 9])
    assert float(np.mean(again.returns)) == pytest.approx(best["return_mean"], rel=1e-12)
    without_eval = _tiny_ppo()
    without_eval.learn(640)
    assert _same_weights(with_eval, without_eval)


def test_training_resumed_from_a_checkpoint_ends_bit_identical(tmp_path) -> None:  # type: ignore[no-untyped-def]
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import BaseCallback

    from chaincart_env.tools.compare.checkpoints import Checkpointer, restore

    class Interrupt(BaseCallback):
        def _on_step(self) -> bool:
            if self.num_timesteps >= 600:
                raise KeyboardInterrupt
            return True

    whole, broken = tmp_path / "whole", tmp_path / "broken"
    whole.mkdir(), broken.mkdir()
    uninterrupted = _tiny_ppo()
    uninterrupted.learn(1024, callback=Checkpointer(whole, every=256))
    interrupted = _tiny_ppo()
    with pytest.raises(KeyboardInterrupt):
        interrupted.learn(1024, callback=[Checkpointer(broken, every=256), Interrupt()])
    resumed, state = restore(broken, PPO)
    assert state["timesteps"] == 512 and resumed.num_timesteps == 512
    assert not _same_weights(resumed, uninterrupted)
    resumed.learn(1024 - resumed.num_timesteps, reset_num_timesteps=False, callback=Checkpointer(broken, every=256))
    assert resumed.num_timesteps == 1024 and _same_weights(resumed, uninterrupted)


def test_restore_without_a_checkpoint_names_what_is_missing(tmp_path) -> None:  # type: ignore[no-untyped-def]
    from stable_baselines3 import PPO

    from chaincart_env.tools.compare.checkpoints import restore

    with pytest.raises(ChainCartError, match="no checkpoint"):
        restore(tmp_path, PPO)


def test_gap_axes_change_the_true_system_and_the_oracle_lqr_sees_it() -> None:
    config = ChainCartConfig(scene="inverted-2", max_episode_steps=150, start_noise=0.1)
    lqr = LQRPolicy.from_env(ChainCartEnv(config))
    policies = [("LQR", lqr), ("oracle", LQRPolicy.from_env(ChainCartEnv(config), oracle=True))]
    seeds = list(range(12))
    rows = run_sweep(policies, config, "mismatch", [0.0, 0.4], seeds)
    strip = lambda row: {k: v for k, v in row.items() if k != "policy"}  # noqa: E731
    # No gap: the oracle's design is the nominal one, row for row.
    assert strip(rows[0]) == strip(rows[1])
    # A gap: the oracle designs on each env's true parameters, so it acts differently.
    assert strip(rows[2]) != strip(rows[3])
    base = run_sweep([("LQR", lqr)], config, "start_noise", [0.1], seeds)[0]
    for axis in ("obs_noise", "delay"):
        zero, some = run_sweep([("LQR", lqr)], config, axis, [0.0, 2.0 if axis == "delay" else 0.05], seeds)
        assert strip(zero) | {"axis": "start_noise", "value": 0.1} == strip(base)
        assert strip(some) != strip(zero)
