"""The elapsed-time observation: the fraction of the episode on every observation, for
one env and an SB3 VecEnv alike (clocks restarted at autoresets), the policy adapter
that counts the steps itself, and the layout with observation history."""

from __future__ import annotations

from typing import Any

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from chaincart_env import ChainCartConfig, ChainCartEnv
from chaincart_env.elapsed_time import (
    ElapsedTimeObservation,
    ElapsedTimePolicy,
    check_horizon,
    for_plain_env,
    observation_extras,
    timed_space,
)
from chaincart_env.errors import InvalidInputError
from chaincart_env.history import HistoryObservation, history_space

SHORT = ChainCartConfig(max_episode_steps=7, start_noise=0.3)


def action(step: int, n: int = 1) -> np.ndarray:
    return np.array([[np.sin(0.7 * step + i)] for i in range(n)], dtype=np.float32)


def test_the_single_env_observes_the_fraction_of_its_episode() -> None:
    env = ElapsedTimeObservation(ChainCartEnv(SHORT))
    assert env.horizon == 7 and env.observation_space.shape == (SHORT.obs_dim + 1,)
    for episode in range(2):
        obs, _ = env.reset(seed=episode)
        assert obs[-1] == 0.0 and env.observation_space.contains(obs)
        for t in range(1, 8):
            obs, _, terminated, truncated, _ = env.step(action(t)[0])
            assert obs[-1] == pytest.approx(t / 7) and env.observation_space.contains(obs)
            if terminated or truncated:
                break
        assert truncated or terminated


def test_the_single_env_wrapper_passes_gymnasiums_checker() -> None:
    check_env(ElapsedTimeObservation(ChainCartEnv(SHORT)), skip_render_check=True)


def test_the_horizon_comes_from_the_env_or_is_named() -> None:
    env = gymnasium.make("ChainCart-swingup-2-v0")
    assert ElapsedTimeObservation(env).horizon == env.spec.max_episode_steps
    assert ElapsedTimeObservation(ChainCartEnv(SHORT), horizon=50).horizon == 50
    for bad in (0, -3, 2.5, True):
        with pytest.raises(InvalidInputError, match="horizon"):
            check_horizon(bad)


def test_the_vec_env_restarts_each_clock_at_its_autoreset_as_the_single_env() -> None:
    from chaincart_env.elapsed_time import VecElapsedTimeObservation
    from chaincart_env.sb3 import ChainCartVecEnv

    n = 3
    venv = VecElapsedTimeObservation(ChainCartVecEnv(n, SHORT, seed=11))
    singles = [ElapsedTimeObservation(ChainCartEnv(SHORT)) for _ in range(n)]
    obs = venv.reset()
    expected = np.stack([env.reset(seed=11 + i)[0] for i, env in enumerate(singles)])
    np.testing.assert_allclose(obs, expected, rtol=0, atol=1e-6)
    ended = 0
    for t in range(20):
        obs, _, dones, infos = venv.step(action(t, n))
        for i, env in enumerate(singles):
            single, _, terminated, truncated, _ = env.step(action(t, n)[i])
            if terminated or truncated:
                ended += 1
                assert dones[i] and infos[i]["terminal_observation"][-1] == single[-1]
                np.testing.assert_allclose(infos[i]["terminal_observation"], single, rtol=0, atol=1e-6)
                single, _ = env.reset()
                assert obs[i, -1] == 0.0
            np.testing.assert_allclose(obs[i], single, rtol=0, atol=1e-6, err_msg=f"step {t} env {i}")
    assert ended >= n


class Recorder:
    """A policy that records what it observes and answers :attr:`answer` (zeros)."""

    def __init__(self, observation_space: Any) -> None:
        self.observation_space = observation_space
        self.seen: list[np.ndarray] = []
        self.answer = np.zeros(1, dtype=np.float32)

    def predict(self, observation: Any, state: Any = None, episode_start: Any = None,
                deterministic: bool = True) -> tuple[np.ndarray, Any]:
        batch = np.atleast_2d(observation)
        self.seen.append(batch.copy())
        return np.tile(self.answer, (batch.shape[0], 1)), state


def test_the_policy_adapter_counts_steps_and_restarts_where_episodes_start() -> None:
    space = ChainCartEnv(SHORT).observation_space
    inner = Recorder(timed_space(space))
    policy = ElapsedTimePolicy(inner, 10, space)
    obs = np.zeros((2, space.shape[0]), dtype=np.float32)
    for _ in range(3):
        policy.predict(obs)
    policy.predict(obs, episode_start=np.array([True, False]))
    clocks = np.array([row[:, -1] for row in inner.seen])
    np.testing.assert_allclose(clocks, [[0, 0], [0.1, 0.1], [0.2, 0.2], [0, 0.3]], rtol=1e-6)
    policy.reset()
    policy.predict(obs[0])
    assert inner.seen[-1][:, -1].tolist() == [0.0]


def test_the_extras_are_read_from_the_policys_observation_space() -> None:
    env = ChainCartEnv(SHORT)
    obs, act = env.observation_space, env.action_space
    assert observation_extras(None, obs, act) == (0, False)
    assert observation_extras(obs, obs, act) == (0, False)
    assert observation_extras(timed_space(obs), obs, act) == (0, True)
    assert observation_extras(history_space(obs, act, 2), obs, act) == (2, False)
    assert observation_extras(timed_space(history_space(obs, act, 1)), obs, act) == (1, True)
    odd = gymnasium.spaces.Box(-1, 1, (obs.shape[0] + 2,))
    with pytest.raises(InvalidInputError, match="plus 1 with the elapsed time"):
        observation_extras(odd, obs, act)


def test_with_history_the_time_comes_last_as_the_training_wrappers_lay_it_out() -> None:
    """The adapter of an agent trained on ElapsedTimeObservation(HistoryObservation(env))
    feeds it what those wrappers would have: the same observations, step for step."""
    plain = ChainCartEnv(SHORT)
    wrapped = ElapsedTimeObservation(HistoryObservation(ChainCartEnv(SHORT), 2))
    inner = Recorder(wrapped.observation_space)
    policy = for_plain_env(inner, plain.observation_space, plain.action_space, SHORT.max_episode_steps)
    obs, _ = plain.reset(seed=5)
    expected, _ = wrapped.reset(seed=5)
    starts = np.array([True])
    for t in range(12):
        inner.answer = action(t)[0]  # what the env is sent, which the history records
        policy.predict(obs, episode_start=starts)
        np.testing.assert_allclose(inner.seen[-1][0], expected, rtol=0, atol=1e-6, err_msg=f"step {t}")
        obs, _, terminated, truncated, _ = plain.step(action(t)[0])
        expected, *_ = wrapped.step(action(t)[0])
        starts = np.array([terminated or truncated])
        if starts[0]:
            obs, _ = plain.reset(seed=6 + t)
            expected, _ = wrapped.reset(seed=6 + t)
