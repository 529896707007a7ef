"""A control delay drawn per episode (``action_delay=(low, high)``): reproducible under a
seed, the same in a batch as alone, covering its range, each episode acting as the
fixed delay it drew, and checked with clear errors."""

from __future__ import annotations

import numpy as np
import pytest

from chaincart_env import ChainCartConfig, ChainCartEnv, InvalidInputError
from chaincart_env.errors import InvalidTypeError

SCENE = dict(scene="inverted-1", max_episode_steps=12)


def _actions(steps: int, seed: int = 7) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-1, 1, size=(steps, 1)).astype(np.float32)


def _episodes(env: ChainCartEnv, seed: int, actions: np.ndarray) -> list[np.ndarray]:
    """Every observation over ``len(actions)`` steps, resetting (unseeded) as episodes end."""
    obs, _ = env.reset(seed=seed)
    out = [obs]
    for action in actions:
        obs, _, terminated, truncated, _ = env.step(action)
        out.append(obs)
        if terminated or truncated:
            obs, _ = env.reset()
            out.append(obs)
    return out


def _delays(batch, resets: int, seed: int) -> list[int]:
    """The delay drawn at each of ``resets`` seeded resets of a one-env batch."""
    out = []
    for k in range(resets):
        batch.reset([seed + k], None)
        out.append(int(batch.snapshot()["action_delays"][0]))
    return out


def test_the_range_is_kept_in_canonical_form_and_a_range_of_one_is_that_delay() -> None:
    assert ChainCartConfig(action_delay=(0, 2)).action_delay == (0, 2)
    assert ChainCartConfig(action_delay=[1, 3]).action_delay == (1, 3)
    assert ChainCartConfig(action_delay=(2, 2)).action_delay == 2
    assert ChainCartConfig(action_delay=1).action_delay == 1
    config = ChainCartConfig(action_delay=(0, 2))
    assert ChainCartConfig(**config.to_dict()) == config


@pytest.mark.parametrize(
    "bad, error",
    [((2, 1), InvalidInputError), ((-1, 2), InvalidInputError), ((0, 1, 2), InvalidInputError),
     (-1, InvalidInputError), ((0.5, 1), InvalidTypeError), ("1", InvalidTypeError), ((0, "2"), InvalidTypeError)],
)  # fmt: skip
def test_bad_delays_are_refused_naming_the_value_and_what_is_expected(bad, error) -> None:
    with pytest.raises(error) as caught:
        ChainCartConfig(action_delay=bad)
    message = str(caught.value)
    assert f"action_delay = {bad!r}" in message
    assert "an integer >= 0 (control periods), or a range (low, high) of integers with 0 <= low <= high" in message


def test_a_seeded_env_repeats_bit_for_bit_over_several_episodes() -> None:
    actions = _actions(60)
    first = _episodes(ChainCartEnv(**SCENE, action_delay=(0, 2)), 11, actions)
    second = _episodes(ChainCartEnv(**SCENE, action_delay=(0, 2)), 11, actions)
    assert len(first) > 60 + 3  # several episodes
    for a, b in zip(first, second, strict=True):
        assert a.tobytes() == b.tobytes()


def test_env_i_of_a_batch_seeded_s_is_the_single_env_seeded_s_plus_i() -> None:
    from chaincart_env import ChainCartVecEnv

    n, seed, steps = 3, 20, 40
    actions = np.stack([_actions(steps, seed=i) for i in range(n)], axis=1)
    venv = ChainCartVecEnv(n, ChainCartConfig(**SCENE, action_delay=(0, 3)), seed=seed)
    batch_obs = [venv.reset()]
    finals: list[dict[int, np.ndarray]] = []
    for k in range(steps):
        obs, _, dones, infos = venv.step(actions[k])
        batch_obs.append(obs)
        finals.append({i: infos[i]["terminal_observation"] for i in np.flatnonzero(dones)})
    for i in range(n):
        env = ChainCartEnv(**SCENE, action_delay=(0, 3))
        obs, _ = env.reset(seed=seed + i)
        assert obs.tobytes() == batch_obs[0][i].tobytes()
        for k in range(steps):
            obs, _, terminated, truncated, _ = env.step(actions[k, i])
            if terminated or truncated:  # the batch resets at once; its final observation is in the info
                assert obs.tobytes() == finals[k][i].tobytes()
                obs, _ = env.reset()
            else:
                assert i not in finals[k]
            assert obs.tobytes() == batch_obs[k + 1][i].tobytes(), (i, k)


def test_the_drawn_delays_cover_the_range_evenly() -> None:
    batch = ChainCartConfig(**SCENE, action_delay=(0, 2)).make_batch(1, "disabled")
    delays = _delays(batch, 600, seed=0)
    counts = np.bincount(delays, minlength=3)
    assert set(delays) == {0, 1, 2}
    # Uniform: each value 200 times, give or take 4 binomial standard deviations (~46).
    assert np.all(np.abs(counts - 200) < 46), counts
    fixed = ChainCartConfig(**SCENE, action_delay=1).make_batch(1, "disabled")
    assert set(_delays(fixed, 20, seed=0)) == {1}


def test_each_episode_acts_as_the_fixed_delay_it_drew() -> None:
    """The delay is drawn after the start state: a seeded episode starts where the
    fixed-delay env's does, and with the delay it drew it follows that env step for step."""
    actions = _actions(11)
    seen = set()
    for seed in range(12):
        ranged = ChainCartEnv(**SCENE, action_delay=(0, 3))
        first, _ = ranged.reset(seed=seed)
        delay = int(ranged._batch.snapshot()["action_delays"][0])
        seen.add(delay)
        fixed = ChainCartEnv(**SCENE, action_delay=delay)
        start, _ = fixed.reset(seed=seed)
        assert first.tobytes() == start.tobytes()
        for action in actions:
            assert ranged.step(action)[0].tobytes() == fixed.step(action)[0].tobytes()
    assert len(seen) >= 3


def test_a_snapshot_keeps_the_episode_delay() -> None:
    batch = ChainCartConfig(**SCENE, action_delay=(0, 3)).make_batch(4, "disabled")
    batch.reset([5, 6, 7, 8], None)
    snap = batch.snapshot()
    actions = _actions(6).repeat(4, axis=1).reshape(6, 4, 1)
    ahead = [batch.step(a)[0].copy() for a in actions]
    batch.restore(snap)
    again = [batch.step(a)[0].copy() for a in actions]
    assert all(a.tobytes() == b.tobytes() for a, b in zip(ahead, again, strict=True))
