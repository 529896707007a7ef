"""Observation and action history for policies that must cope with a control delay.

A policy that sees only the current observation cannot tell which of its past actions
are still on their way to the actuator (``action_delay``); given the last few
observations and actions it can. Two wrappers append them to every observation:

* :class:`HistoryObservation` for one Gymnasium env (``ChainCartEnv`` or any env with
  ``Box`` observation and action spaces);
* :class:`VecHistoryObservation` for a stable-baselines3 ``VecEnv``
  (``ChainCartVecEnv``), each env's history kept apart and restarted where that env's
  episode ends (same-step autoreset, as SB3 expects).

With ``k`` steps of history the observation at step ``t`` of an episode is::

    [ o_t,  o_{t-k}, ..., o_{t-1},  a_{t-k}, ..., a_{t-1} ]

the current observation, then the ``k`` observations before it, oldest first, then
the ``k`` actions sent before it (clipped to the action space, as the env applies
them), oldest first: ``a_{t-1}`` is the action that led to ``o_t``. Entries from
before the episode's start are zeros (not copies of the first observation: zeros say
"no history yet", and a copy would mimic a chain at rest). Its length is
``obs_dim + k * (obs_dim + action_dim)``. A finished episode's
``terminal_observation`` (vector wrapper) carries that episode's history.

An agent trained on such observations acts on the plain env through
:class:`HistoryPolicy`, which keeps the same history from the observations it is given
and the actions it returns (episodes begin where ``episode_start`` says, SB3's
convention); :func:`with_history` wraps an agent whose observation space says it needs
one.
"""

from __future__ import annotations

import functools
from typing import Any, Optional

import gymnasium
import numpy as np

from chaincart_env.errors import InvalidInputError

__all__ = [
    "HistoryObservation", "HistoryPolicy", "PicklableVecWrapper", "VecHistoryObservation", "check_history",
    "history_of", "history_space", "with_history",
]  # fmt: skip


class PicklableVecWrapper:
    """Mixin for a stable-baselines3 ``VecEnvWrapper`` that must pickle with its envs
    (compare's checkpoints pickle the training envs): ``VecEnvWrapper`` keeps a table of
    its class's members, which does not pickle, so the state leaves it out and a
    restored wrapper builds it again. Put it before ``VecEnvWrapper`` among the bases."""

    def __getstate__(self) -> dict[str, Any]:
        state = dict(self.__dict__)
        state.pop("class_attributes", None)
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        import inspect

        self.__dict__.update(state)
        self.class_attributes = dict(inspect.getmembers(self.__class__))


def check_history(k: Any) -> int:
    """``k`` as a number of steps of history: an integer >= 1."""
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1:
        raise InvalidInputError(f"history = {k!r}: expected an integer >= 1 (steps of history)")
    return int(k)


def _box(space: Any, what: str) -> gymnasium.spaces.Box:
    if not isinstance(space, gymnasium.spaces.Box) or len(space.shape) != 1:
        raise InvalidInputError(f"{what} space {space!r}: expected a one-dimensional Box")
    return space


def history_space(observation_space: Any, action_space: Any, k: int) -> gymnasium.spaces.Box:
    """The observation space with ``k`` steps of history appended (module docstring);
    its bounds hold the zeros of the padding."""
    obs, act = _box(observation_space, "observation"), _box(action_space, "action")
    dtype: Any = obs.dtype
    parts_low = [obs.low, np.tile(np.minimum(obs.low, 0), k), np.tile(np.minimum(act.low, 0), k)]
    parts_high = [obs.high, np.tile(np.maximum(obs.high, 0), k), np.tile(np.maximum(act.high, 0), k)]
    low = np.concatenate([np.asarray(p, dtype=np.float64) for p in parts_low]).astype(dtype)
    high = np.concatenate([np.asarray(p, dtype=np.float64) for p in parts_high]).astype(dtype)
    return gymnasium.spaces.Box(low=low, high=high, dtype=dtype)


class _Buffers:
    """The history of ``n`` envs: the current observation, the ``k`` observations
    before it and the ``k`` actions sent before it (oldest first), zeros before an
    episode's start."""

    def __init__(self, n: int, k: int, obs_dim: int, action_space: gymnasium.spaces.Box, dtype: Any) -> None:
        self.action_space, self.dtype = action_space, dtype
        self.current = np.zeros((n, obs_dim), dtype=dtype)
        self.observations = np.zeros((n, k, obs_dim), dtype=dtype)
        self.actions = np.zeros((n, k, action_space.shape[0]), dtype=dtype)

    def restart(self, envs: Any, first_observations: np.ndarray) -> None:
        """Envs ``envs`` begin episodes at ``first_observations``: no history."""
        self.observations[envs] = 0
        self.actions[envs] = 0
        self.current[envs] = first_observations

    def advance(self, actions: np.ndarray) -> None:
        """Every env sent ``actions`` from its current observation: both join the history."""
        sent = np.clip(np.asarray(actions, dtype=np.float64).reshape(self.actions.shape[0], -1),
                       self.action_space.low, self.action_space.high)
        self.observations[:, :-1] = self.observations[:, 1:]
        self.observations[:, -1] = self.current
        self.actions[:, :-1] = self.actions[:, 1:]
        self.actions[:, -1] = sent

    def augmented(self, observations: np.ndarray, envs: Any = slice(None)) -> np.ndarray:
        """``observations`` of envs ``envs`` with those envs' history appended."""
        obs = np.asarray(observations, dtype=self.dtype).reshape(-1, self.current.shape[1])
        past = self.observations[envs].reshape(obs.shape[0], -1)
        sent = self.actions[envs].reshape(obs.shape[0], -1)
        return np.concatenate([obs, past, sent], axis=1)


class HistoryObservation(gymnasium.Wrapper):
    """A Gymnasium env whose observations carry the last ``k`` observations and actions
    (module docstring: order, zeros before the episode's start)."""

    def __init__(self, env: gymnasium.Env, k: int) -> None:
        super().__init__(env)
        self.k = check_history(k)
        self.observation_space = history_space(env.observation_space, env.action_space, self.k)
        inner = _box(env.observation_space, "observation")
        self._buffers = _Buffers(1, self.k, inner.shape[0], _box(env.action_space, "action"), inner.dtype)

    def reset(self, *, seed: Optional[int] = None, options: Optional[dict[str, Any]] = None) -> tuple[np.ndarray, dict]:
        """The env's reset, its first observation with an empty (zero) history."""
        obs, info = self.env.reset(seed=seed, options=options)
        self._buffers.restart(slice(None), np.asarray(obs)[None])
        return self._buffers.augmented(obs)[0], info

    def step(self, action: Any) -> tuple[np.ndarray, Any, bool, bool, dict]:
        """The env's step, its observation with the history up to this action."""
        obs, reward, terminated, truncated, info = self.env.step(action)
        self._buffers.advance(np.asarray(action)[None])
        self._buffers.current[0] = obs
        return self._buffers.augmented(obs)[0], reward, terminated, truncated, info


class HistoryPolicy:
    """A policy trained on observations with ``k`` steps of history, acting on plain
    observations (one, or a batch of envs): it appends each env's history, asks
    ``policy`` and records the actions it returns. ``episode_start`` (one bool per env,
    SB3's convention) restarts an env's history; without it, only the first call does."""

    def __init__(self, policy: Any, k: int, observation_space: Any, action_space: Any) -> None:
        self.policy, self.k = policy, check_history(k)
        inner = _box(observation_space, "observation")
        self.observation_space = history_space(inner, action_space, self.k)
        self._action_space = _box(action_space, "action")
        self._obs_dim, self._dtype = inner.shape[0], inner.dtype
        self._buffers: Optional[_Buffers] = None

    def predict(
        self, observation: Any, state: Any = None, episode_start: Any = None, deterministic: bool = True
    ) -> tuple[np.ndarray, Any]:
        """``policy.predict`` on the observations with their histories."""
        single = np.asarray(observation).ndim == 1
        obs = np.asarray(observation, dtype=self._dtype).reshape(-1, self._obs_dim)
        n = obs.shape[0]
        if self._buffers is None or self._buffers.current.shape[0] != n:
            self._buffers = _Buffers(n, self.k, self._obs_dim, self._action_space, self._dtype)
            starts = np.ones(n, dtype=bool)
        elif episode_start is None:
            starts = np.zeros(n, dtype=bool)
        else:
            starts = np.asarray(episode_start, dtype=bool).reshape(-1)
        self._buffers.current[:] = obs
        if starts.any():
            self._buffers.restart(np.flatnonzero(starts), obs[starts])
        actions, state = self.policy.predict(
            self._buffers.augmented(obs), state=state, episode_start=episode_start, deterministic=deterministic
        )
        batch = np.asarray(actions).reshape(n, -1)
        self._buffers.advance(batch)
        return (batch[0] if single else batch), state

    def reset(self) -> None:
        """Forgets every env's history (the next call begins new episodes), and resets
        ``policy`` too where it keeps its own per-episode state (a clock)."""
        self._buffers = None
        inner_reset = getattr(self.policy, "reset", None)
        if callable(inner_reset):
            inner_reset()


def history_of(policy: Any, observation_space: Any, action_space: Any) -> int:
    """The steps of history ``policy`` (with an ``observation_space``) expects on an env
    with these spaces: 0 when its observations are the env's own."""
    space = getattr(policy, "observation_space", None)
    if space is None or getattr(space, "shape", None) == observation_space.shape:
        return 0
    obs, act = _box(observation_space, "observation").shape[0], _box(action_space, "action").shape[0]
    extra = int(np.prod(space.shape)) - obs
    if extra <= 0 or extra % (obs + act):
        raise InvalidInputError(
            f"a policy observing {space.shape} on an env observing ({obs},) with {act} actions: expected "
            f"{obs} + k * ({obs} + {act}) numbers for k steps of history"
        )
    return extra // (obs + act)


def with_history(policy: Any, observation_space: Any, action_space: Any) -> Any:
    """``policy`` itself, or wrapped in :class:`HistoryPolicy` when its observation
    space holds history (:func:`history_of`)."""
    k = history_of(policy, observation_space, action_space)
    return policy if k == 0 else HistoryPolicy(policy, k, observation_space, action_space)


@functools.cache
def _vec_history_class() -> type:
    """:class:`VecHistoryObservation`, made once, on first use (stable-baselines3 loads then)."""
    from stable_baselines3.common.vec_env import VecEnvWrapper

    class VecHistoryObservation(PicklableVecWrapper, VecEnvWrapper):  # type: ignore[misc]
        """A stable-baselines3 ``VecEnv`` whose observations carry each env's last ``k``
        observations and actions (:mod:`chaincart_env.history`). An env whose episode
        ended on this step (same-step autoreset) restarts its history at its new first
        observation; its ``info["terminal_observation"]`` carries the finished episode's
        history."""

        def __init__(self, venv: Any, k: int) -> None:
            k = check_history(k)
            space = history_space(venv.observation_space, venv.action_space, k)
            super().__init__(venv, observation_space=space)
            self.k = k
            inner = _box(venv.observation_space, "observation")
            self._buffers = _Buffers(venv.num_envs, k, inner.shape[0], venv.action_space, inner.dtype)
            self._actions: Optional[np.ndarray] = None

        def reset(self) -> np.ndarray:
            """Resets every env: first observations, empty (zero) histories."""
            obs = np.asarray(self.venv.reset())
            self._buffers.restart(slice(None), obs)
            return self._buffers.augmented(obs)

        def step_async(self, actions: np.ndarray) -> None:
            """Keeps ``actions`` for the history and passes them on."""
            self._actions = np.asarray(actions)
            self.venv.step_async(actions)

        def step_wait(self) -> Any:
            """The envs' step, observations with their histories (restarted where an episode ended)."""
            if self._actions is None:
                raise InvalidInputError("step_wait() without step_async(actions): expected actions first")
            raw_obs, rewards, dones, infos = self.venv.step_wait()
            obs = np.asarray(raw_obs)
            self._buffers.advance(self._actions)
            self._actions = None
            ended = np.flatnonzero(dones)
            for i in ended:
                final = infos[i].get("terminal_observation")
                if final is not None:
                    infos[i]["terminal_observation"] = self._buffers.augmented(final, [int(i)])[0]
            self._buffers.current[:] = obs
            if ended.size:
                self._buffers.restart(ended, obs[ended])
            return self._buffers.augmented(obs), rewards, dones, infos

    VecHistoryObservation.__module__ = __name__
    VecHistoryObservation.__qualname__ = "VecHistoryObservation"
    return VecHistoryObservation


def __getattr__(name: str) -> Any:
    # Lazy: stable-baselines3 (and torch) load only when the VecEnv wrapper is used.
    if name == "VecHistoryObservation":
        return _vec_history_class()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
