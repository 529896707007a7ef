"""Observation and action history (chaincart_env.history): the exact layout on a worked
example, per-env restarts in the vector wrapper, the single env equal to the vector one,
and the policy adapter equal to the wrapper."""

from __future__ import annotations

import gymnasium
import numpy as np
import pytest

from chaincart_env import ChainCartConfig, ChainCartEnv, HistoryObservation, InvalidInputError
from chaincart_env.history import HistoryPolicy, check_history, history_of, with_history


class Counter(gymnasium.Env):
    """Observation ``[t + 1, -(t + 1)]`` at step ``t`` of an episode of ``length`` steps."""

    observation_space = gymnasium.spaces.Box(-np.inf, np.inf, (2,), np.float32)
    action_space = gymnasium.spaces.Box(-1.0, 1.0, (1,), np.float32)

    def __init__(self, length: int = 100) -> None:
        self.length, self.t = length, 0

    def _obs(self) -> np.ndarray:
        return np.array([self.t + 1, -(self.t + 1)], dtype=np.float32)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.t = 0
        return self._obs(), {}

    def step(self, action):
        self.t += 1
        return self._obs(), 0.0, self.t >= self.length, False, {}


def test_the_layout_on_a_worked_example() -> None:
    env = HistoryObservation(Counter(), 2)
    assert env.observation_space.shape == (2 + 2 * (2 + 1),)
    # [o_t, o_{t-2}, o_{t-1}, a_{t-2}, a_{t-1}], zeros before the start, actions clipped.
    expected = [
        [1, -1, 0, 0, 0, 0, 0, 0],
        [2, -2, 0, 0, 1, -1, 0, 0.5],
        [3, -3, 1, -1, 2, -2, 0.5, 1.0],
        [4, -4, 2, -2, 3, -3, 1.0, -0.25],
    ]
    obs, _ = env.reset()
    seen = [obs]
    for action in (0.5, 2.0, -0.25):
        seen.append(env.step(np.array([action], dtype=np.float32))[0])
    np.testing.assert_array_equal(np.array(seen), np.array(expected, dtype=np.float32))
    # A new episode starts with no history.
    np.testing.assert_array_equal(env.reset()[0], np.array(expected[0], dtype=np.float32))
    assert env.observation_space.contains(seen[2])


def test_the_vector_wrapper_restarts_each_env_where_its_episode_ends() -> None:
    from stable_baselines3.common.vec_env import DummyVecEnv

    from chaincart_env import VecHistoryObservation

    venv = VecHistoryObservation(DummyVecEnv([lambda: Counter(2), lambda: Counter(3)]), 1)
    obs = venv.reset()
    np.testing.assert_array_equal(obs, [[1, -1, 0, 0, 0], [1, -1, 0, 0, 0]])
    obs, _, dones, infos = venv.step(np.array([[0.1], [0.2]], dtype=np.float32))
    np.testing.assert_array_equal(obs, np.array([[2, -2, 1, -1, 0.1], [2, -2, 1, -1, 0.2]], dtype=np.float32))
    # Env 0 ends: its new episode has no history; its final observation has the old one.
    obs, _, dones, infos = venv.step(np.array([[0.3], [0.4]], dtype=np.float32))
    assert list(dones) == [True, False]
    np.testing.assert_array_equal(obs, np.array([[1, -1, 0, 0, 0], [3, -3, 2, -2, 0.4]], dtype=np.float32))
    np.testing.assert_array_equal(infos[0]["terminal_observation"], np.array([3, -3, 2, -2, 0.3], dtype=np.float32))
    obs, _, dones, infos = venv.step(np.array([[0.5], [0.6]], dtype=np.float32))
    assert list(dones) == [False, True]
    np.testing.assert_array_equal(obs, np.array([[2, -2, 1, -1, 0.5], [1, -1, 0, 0, 0]], dtype=np.float32))
    np.testing.assert_array_equal(infos[1]["terminal_observation"], np.array([4, -4, 3, -3, 0.6], dtype=np.float32))


def test_env_i_of_the_vector_wrapper_is_the_single_wrapper_seeded_s_plus_i() -> None:
    from chaincart_env import ChainCartVecEnv, VecHistoryObservation

    n, seed, steps, k = 3, 4, 30, 3
    config = ChainCartConfig(scene="inverted-1", max_episode_steps=11, action_delay=(0, 2))
    actions = np.random.default_rng(0).uniform(-1.5, 1.5, size=(steps, n, 1)).astype(np.float32)
    venv = VecHistoryObservation(ChainCartVecEnv(n, config, seed=seed), k)
    batch = [venv.reset()]
    finals = []
    for a in actions:
        obs, _, dones, infos = venv.step(a)
        batch.append(obs)
        finals.append({i: infos[i]["terminal_observation"] for i in np.flatnonzero(dones)})
    assert any(finals)
    for i in range(n):
        env = HistoryObservation(ChainCartEnv(config), k)
        obs, _ = env.reset(seed=seed + i)
        assert obs.tobytes() == batch[0][i].tobytes()
        for t in range(steps):
            obs, _, terminated, truncated, _ = env.step(actions[t, i])
            if terminated or truncated:
                assert obs.tobytes() == finals[t][i].tobytes()
                obs, _ = env.reset()
            assert obs.tobytes() == batch[t + 1][i].tobytes(), (i, t)


class Linear:
    """A deterministic policy of the augmented observation (a stand-in for an agent)."""

    def __init__(self, space: gymnasium.spaces.Box) -> None:
        self.observation_space = space
        self.weights = np.random.default_rng(1).normal(size=space.shape[0]) * 0.3

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        obs = np.atleast_2d(observation)
        return np.tanh(obs @ self.weights)[:, None].astype(np.float32), state


def test_the_policy_adapter_sees_what_the_wrapper_shows() -> None:
    from chaincart_env import ChainCartVecEnv, VecHistoryObservation

    n, k, steps = 2, 2, 25
    config = ChainCartConfig(scene="inverted-1", max_episode_steps=9)
    venv = VecHistoryObservation(ChainCartVecEnv(n, config, seed=3), k)
    agent = Linear(venv.observation_space)
    plain = ChainCartVecEnv(n, config, seed=3)
    adapter = with_history(agent, plain.observation_space, plain.action_space)
    assert isinstance(adapter, HistoryPolicy) and adapter.k == k
    wrapped_obs, raw_obs = venv.reset(), plain.reset()
    starts = np.ones(n, dtype=bool)
    for _ in range(steps):
        wrapped_actions, _ = agent.predict(wrapped_obs)
        adapter_actions, _ = adapter.predict(raw_obs, episode_start=starts)
        assert wrapped_actions.tobytes() == adapter_actions.tobytes()
        wrapped_obs, _, _, _ = venv.step(wrapped_actions)
        raw_obs, _, starts, _ = plain.step(adapter_actions)
    # An agent without history is given as it is; a shape that fits no history is refused.
    bare = Linear(plain.observation_space)
    assert with_history(bare, plain.observation_space, plain.action_space) is bare
    odd = Linear(gymnasium.spaces.Box(-1, 1, (plain.observation_space.shape[0] + 1,)))
    with pytest.raises(InvalidInputError, match=r"expected 5 \+ k \* \(5 \+ 1\) numbers"):
        history_of(odd, plain.observation_space, plain.action_space)


@pytest.mark.parametrize("bad", [0, -1, 1.5, "2", True, None])
def test_a_bad_history_length_is_refused_naming_it(bad) -> None:
    with pytest.raises(InvalidInputError, match=rf"history = {bad!r}: expected an integer >= 1"):
        check_history(bad)
    with pytest.raises(InvalidInputError):
        HistoryObservation(Counter(), bad)


def test_the_vector_wrapper_pickles_with_its_histories() -> None:
    """compare's checkpoints pickle the training envs: a copy continues as the original."""
    import pickle

    from chaincart_env import ChainCartVecEnv, VecHistoryObservation

    venv = VecHistoryObservation(ChainCartVecEnv(2, scene="inverted-1", seed=5), 2)
    venv.reset()
    venv.step(np.full((2, 1), 0.3, dtype=np.float32))
    copy = pickle.loads(pickle.dumps(venv))
    assert type(copy) is VecHistoryObservation and copy.k == 2
    for action in (-0.5, 0.7):
        actions = np.full((2, 1), action, dtype=np.float32)
        assert venv.step(actions)[0].tobytes() == copy.step(actions)[0].tobytes()
