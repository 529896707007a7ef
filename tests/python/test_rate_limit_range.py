"""A force-rate limit drawn per episode (``force_rate_limit=(low, high)``, high up to
``inf``): reproducible under a seed, the same in a batch as alone, spread over its range
(its inverse uniform), each episode acting as the fixed limit it drew, kept by a
snapshot, and checked with clear errors."""

from __future__ import annotations

import math

import numpy as np
import pytest

from chaincart_env import ChainCartConfig, ChainCartEnv, ChainCartVecEnv, InvalidInputError
from chaincart_env.errors import InvalidTypeError

SCENE = dict(scene="inverted-1", max_episode_steps=12, max_force=20.0)
RANGE = (200.0, math.inf)


def _actions(steps: int, seed: int = 7) -> np.ndarray:
    return np.random.default_rng(seed).choice([-1.0, 1.0], size=(steps, 1)).astype(np.float32)


def _limit(env: ChainCartEnv) -> float:
    """The limit of the env's current episode (kept after its last force)."""
    return float(env._batch.snapshot()["last_force"][-1])


def test_the_range_is_kept_and_round_trips() -> None:
    config = ChainCartConfig(force_rate_limit=RANGE)
    assert config.force_rate_limit == RANGE
    assert ChainCartConfig(**config.to_dict()) == config
    assert ChainCartConfig(force_rate_limit=[300, 900]).force_rate_limit == (300.0, 900.0)


@pytest.mark.parametrize(
    "bad, error, named",
    [((500.0, 200.0), InvalidInputError, "200"), ((0.0, 100.0), InvalidInputError, "0"),
     ((math.inf, math.inf), InvalidInputError, "inf"), ((1.0, 2.0, 3.0), InvalidInputError, "(1.0, 2.0, 3.0)"),
     (("a", 2.0), InvalidTypeError, "('a', 2.0)")],
)  # fmt: skip
def test_bad_ranges_are_refused_naming_the_value_and_what_is_expected(bad, error, named) -> None:
    with pytest.raises(error) as caught:
        ChainCartEnv(force_rate_limit=bad)
    message = str(caught.value)
    assert f"force_rate_limit = {named}" in message
    assert "or a range (low, high) with 0 < low <= high <= inf drawn per episode" in message


def test_a_seeded_env_repeats_bit_for_bit_over_several_episodes() -> None:
    runs = []
    for _ in range(2):
        env = ChainCartEnv(**SCENE, force_rate_limit=RANGE)
        obs, _ = env.reset(seed=3)
        seen, limits = [obs], [_limit(env)]
        for action in _actions(50):
            obs, _, terminated, truncated, _ = env.step(action)
            seen.append(obs)
            if terminated or truncated:
                obs, _ = env.reset()
                seen.append(obs)
                limits.append(_limit(env))
        runs.append((np.array(seen), limits))
    assert runs[0][0].tobytes() == runs[1][0].tobytes() and runs[0][1] == runs[1][1]
    assert len(set(runs[0][1])) >= 3  # a new limit every episode


def test_env_i_of_a_batch_seeded_s_is_the_single_env_seeded_s_plus_i() -> None:
    n, seed, steps = 3, 20, 40
    actions = np.stack([_actions(steps, seed=i) for i in range(n)], axis=1)
    venv = ChainCartVecEnv(n, ChainCartConfig(**SCENE, force_rate_limit=RANGE), seed=seed)
    batch_obs = [venv.reset()]
    for k in range(steps):
        batch_obs.append(venv.step(actions[k])[0])
    for i in range(n):
        env = ChainCartEnv(**SCENE, force_rate_limit=RANGE)
        obs, _ = env.reset(seed=seed + i)
        assert obs.tobytes() == batch_obs[0][i].tobytes()
        for k in range(steps):
            obs, _, terminated, truncated, _ = env.step(actions[k, i])
            if terminated or truncated:
                obs, _ = env.reset()
            assert obs.tobytes() == batch_obs[k + 1][i].tobytes(), (i, k)


def test_the_drawn_limits_have_a_uniform_inverse_over_the_range() -> None:
    env = ChainCartEnv(**SCENE, force_rate_limit=RANGE)
    inverses = []
    for seed in range(400):
        env.reset(seed=seed)
        inverses.append(1.0 / _limit(env))
    inverses = np.array(inverses) * RANGE[0]  # uniform on [0, 1]
    assert inverses.min() >= 0.0 and inverses.max() <= 1.0
    # Each quarter holds 100 of 400, give or take 4 binomial standard deviations (~35).
    counts = np.histogram(inverses, bins=4, range=(0.0, 1.0))[0]
    assert np.all(np.abs(counts - 100) < 35), counts


def test_each_episode_acts_as_the_fixed_limit_it_drew() -> None:
    """The limit is drawn after the start state: a seeded episode starts where the
    fixed-limit env's does and, with the limit it drew, follows it step for step."""
    actions = _actions(11)
    for seed in range(8):
        ranged = ChainCartEnv(**SCENE, force_rate_limit=(100.0, 2000.0))
        first, _ = ranged.reset(seed=seed)
        fixed = ChainCartEnv(**SCENE, force_rate_limit=_limit(ranged))
        start, _ = fixed.reset(seed=seed)
        assert first.tobytes() == start.tobytes()
        for action in actions:
            assert ranged.step(action)[0].tobytes() == fixed.step(action)[0].tobytes()


def test_a_snapshot_keeps_the_episode_limit() -> None:
    batch = ChainCartConfig(**SCENE, force_rate_limit=RANGE).make_batch(4, "disabled")
    batch.reset([5, 6, 7, 8], None)
    snap = batch.snapshot()
    actions = _actions(6).repeat(4, axis=1).reshape(6, 4, 1)
    ahead = [batch.step(a)[0].copy() for a in actions]
    batch.restore(snap)
    again = [batch.step(a)[0].copy() for a in actions]
    assert all(a.tobytes() == b.tobytes() for a, b in zip(ahead, again, strict=True))


def test_the_command_line_takes_an_open_range_written_with_inf() -> None:
    import argparse

    from chaincart_env.tools.compare.scene_options import add_scene_options, config_from_options

    parser = argparse.ArgumentParser()
    add_scene_options(parser)
    for text in ("[200,inf]", "200,inf", "[200, Infinity]"):
        config = config_from_options(parser.parse_args(["--scene", "swingup-2", "--force-rate-limit", text]))
        assert config.force_rate_limit == (200.0, math.inf), text
