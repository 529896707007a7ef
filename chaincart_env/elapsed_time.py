"""The elapsed time of the episode as an observation, for policies that follow a clock.

A controller that tracks a plan acts on the state *and* on where the plan is at that
moment: the planner's time-varying LQR applies ``u(t) = u_ref(t) - K(t) (x - x_ref(t))``.
A policy of the state alone cannot copy it (two visits to one state at different times
ask for different forces); given the time it can. The wrappers here append the fraction
of the episode that has elapsed,

    tau_t = t / horizon,

``t`` the steps since the episode's reset (0 on its first observation) and ``horizon``
the env's episode length in steps (its ``max_episode_steps``), so ``tau`` runs from 0
to 1 whatever the control period. It is one number at the end of the observation:

* :class:`ElapsedTimeObservation` for one Gymnasium env;
* :class:`VecElapsedTimeObservation` for a stable-baselines3 ``VecEnv``, each env's
  clock restarted where its episode ends (same-step autoreset; a finished episode's
  ``terminal_observation`` carries its final time);
* :class:`ElapsedTimePolicy` for an agent trained on such observations acting on the
  plain env: it counts each env's steps itself, restarting where ``episode_start``
  says (SB3's convention; without it, only the first call starts episodes).

With observation history (:mod:`chaincart_env.history`) as well, the time comes last:
``[o_t, history..., tau_t]`` (the history wrapper inside, this one outside).
:func:`for_plain_env` wraps an agent whose observation space says it needs either.
"""

from __future__ import annotations

import functools
from typing import Any, Optional

import gymnasium
import numpy as np

from chaincart_env.errors import InvalidInputError
from chaincart_env.history import HistoryPolicy, PicklableVecWrapper, check_history, history_space

__all__ = [
    "ElapsedTimeObservation", "ElapsedTimePolicy", "VecElapsedTimeObservation", "check_horizon", "for_plain_env",
    "observation_extras", "timed_space", "with_adapters", "with_observation_extras",
]  # fmt: skip


def check_horizon(horizon: Any) -> int:
    """``horizon`` as an episode length in steps: an integer >= 1."""
    if isinstance(horizon, bool) or not isinstance(horizon, (int, np.integer)) or horizon < 1:
        raise InvalidInputError(f"horizon = {horizon!r}: expected an integer >= 1 (the episode's length in steps)")
    return int(horizon)


def _box(space: Any) -> gymnasium.spaces.Box:
    if not isinstance(space, gymnasium.spaces.Box) or len(space.shape) != 1:
        raise InvalidInputError(f"observation space {space!r}: expected a one-dimensional Box")
    return space


def timed_space(observation_space: Any) -> gymnasium.spaces.Box:
    """The observation space with the elapsed fraction appended, bounded by [0, 1]."""
    obs = _box(observation_space)
    low = np.append(np.asarray(obs.low, dtype=np.float64), 0.0).astype(obs.dtype)
    high = np.append(np.asarray(obs.high, dtype=np.float64), 1.0).astype(obs.dtype)
    dtype: Any = obs.dtype
    return gymnasium.spaces.Box(low=low, high=high, dtype=dtype)


def _horizon_of(env: Any, horizon: Optional[int]) -> int:
    """``horizon``, or the env's episode length (its spec's ``max_episode_steps``, else
    its chaincart config's)."""
    if horizon is not None:
        return check_horizon(horizon)
    spec = getattr(env, "spec", None)
    steps = getattr(spec, "max_episode_steps", None)
    if steps is None:
        config = getattr(getattr(env, "unwrapped", env), "config", None)
        steps = getattr(config, "max_episode_steps", None)
    if steps is None:
        raise InvalidInputError(f"{type(env).__name__} states no episode length: expected horizon=<steps>")
    return check_horizon(steps)


def _appended(observations: Any, clocks: np.ndarray, horizon: int, dtype: Any) -> np.ndarray:
    obs = np.asarray(observations, dtype=dtype).reshape(clocks.shape[0], -1)
    return np.concatenate([obs, (clocks / horizon).astype(dtype)[:, None]], axis=1)


class ElapsedTimeObservation(gymnasium.Wrapper):
    """A Gymnasium env whose observations end with the elapsed fraction of the episode
    (module docstring); ``horizon`` defaults to the env's ``max_episode_steps``."""

    def __init__(self, env: gymnasium.Env, horizon: Optional[int] = None) -> None:
        super().__init__(env)
        self.horizon = _horizon_of(env, horizon)
        self.observation_space = timed_space(env.observation_space)
        self._clock = np.zeros(1)

    def reset(self, *, seed: Optional[int] = None, options: Optional[dict[str, Any]] = None) -> tuple[np.ndarray, dict]:
        """The env's reset, at time 0."""
        obs, info = self.env.reset(seed=seed, options=options)
        self._clock[:] = 0
        return _appended(obs, self._clock, self.horizon, self.observation_space.dtype)[0], info

    def step(self, action: Any) -> tuple[np.ndarray, Any, bool, bool, dict]:
        """The env's step, one period later."""
        obs, reward, terminated, truncated, info = self.env.step(action)
        self._clock += 1
        return _appended(obs, self._clock, self.horizon, self.observation_space.dtype)[0], reward, terminated, truncated, info


class ElapsedTimePolicy:
    """A policy trained on observations ending with the elapsed time, acting on
    observations without it (one, or a batch of envs): it keeps each env's step count,
    restarted where ``episode_start`` is true (without ``episode_start``, only the first
    call starts episodes, as after :meth:`reset`)."""

    def __init__(self, policy: Any, horizon: int, observation_space: Any) -> None:
        self.policy, self.horizon = policy, check_horizon(horizon)
        self.observation_space = timed_space(observation_space)
        self._width = _box(observation_space).shape[0]
        self._clock: Optional[np.ndarray] = None

    def predict(
        self, observation: Any, state: Any = None, episode_start: Any = None, deterministic: bool = True
    ) -> tuple[np.ndarray, Any]:
        """``policy.predict`` on the observations with each env's elapsed time."""
        single = np.asarray(observation).ndim == 1
        obs = np.asarray(observation).reshape(-1, self._width)
        n = obs.shape[0]
        if self._clock is None or self._clock.shape[0] != n:
            self._clock = np.zeros(n)
        elif episode_start is not None:
            self._clock[np.asarray(episode_start, dtype=bool).reshape(-1)] = 0
        timed = _appended(obs, self._clock, self.horizon, self.observation_space.dtype)
        actions, state = self.policy.predict(timed, state=state, episode_start=episode_start,
                                             deterministic=deterministic)
        self._clock += 1
        batch = np.asarray(actions).reshape(n, -1)
        return (batch[0] if single else batch), state

    def reset(self) -> None:
        """Forgets every env's clock (the next call begins new episodes)."""
        self._clock = None
        inner_reset = getattr(self.policy, "reset", None)
        if callable(inner_reset):
            inner_reset()


def observation_extras(policy_space: Any, observation_space: Any, action_space: Any) -> tuple[int, bool]:
    """``(k, timed)``: the steps of history and whether the elapsed time ends the
    observations of a policy observing ``policy_space`` on an env with these spaces
    (``(0, False)``: the env's own observations)."""
    if policy_space is None or getattr(policy_space, "shape", None) == observation_space.shape:
        return 0, False
    obs, act = _box(observation_space).shape[0], _box(action_space).shape[0]
    extra = int(np.prod(policy_space.shape)) - obs
    k, timed = divmod(extra, obs + act)
    if extra <= 0 or timed > 1:
        raise InvalidInputError(
            f"a policy observing {policy_space.shape} on an env observing ({obs},) with {act} actions: expected "
            f"{obs} + k * ({obs} + {act}) numbers for k steps of history, plus 1 with the elapsed time"
        )
    return k, bool(timed)


def for_plain_env(policy: Any, observation_space: Any, action_space: Any, horizon: int) -> Any:
    """``policy`` acting on an env with these spaces and episodes of ``horizon`` steps:
    itself, or wrapped to append what its observation space holds beyond the env's
    (the elapsed time, :class:`ElapsedTimePolicy`; history,
    :class:`~chaincart_env.history.HistoryPolicy`). An agent that corrects a model-based
    controller needs its base as well: :func:`chaincart_env.residual.on_plain_env`."""
    k, timed = observation_extras(getattr(policy, "observation_space", None), observation_space, action_space)
    return with_adapters(policy, k, horizon if timed else 0, observation_space, action_space)


def with_adapters(policy: Any, history: int, horizon: int, observation_space: Any, action_space: Any) -> Any:
    """``policy``, whose input is an env's observation followed by ``history`` steps of
    history (0: none) and, for ``horizon`` > 0, the elapsed fraction of episodes of
    ``horizon`` steps, acting on the env's plain observations: wrapped in
    :class:`ElapsedTimePolicy` (inside) and :class:`~chaincart_env.history.HistoryPolicy`
    (outside), as the observation is laid out."""
    if horizon:
        inner = history_space(observation_space, action_space, check_history(history)) if history else observation_space
        policy = ElapsedTimePolicy(policy, horizon, inner)
    return HistoryPolicy(policy, history, observation_space, action_space) if history else policy


def with_observation_extras(venv: Any, history: Optional[int], elapsed_time: bool) -> Any:
    """An SB3 ``venv`` observed as an agent with ``history`` steps of history (``None``
    or 0: none) and, with ``elapsed_time``, the elapsed time after it: the wrappers in
    the order that lays the observation out as the module docstring says."""
    if history:
        from chaincart_env.history import VecHistoryObservation

        venv = VecHistoryObservation(venv, history)
    if elapsed_time:
        venv = _vec_elapsed_time_class()(venv)
    return venv


@functools.cache
def _vec_elapsed_time_class() -> type:
    """:class:`VecElapsedTimeObservation`, made once, on first use (stable-baselines3 loads then)."""
    from stable_baselines3.common.vec_env import VecEnvWrapper

    class VecElapsedTimeObservation(PicklableVecWrapper, VecEnvWrapper):  # type: ignore[misc]
        """A stable-baselines3 ``VecEnv`` whose observations end with each env's elapsed
        fraction of its episode (:mod:`chaincart_env.elapsed_time`); ``horizon``
        defaults to the envs' ``max_episode_steps``. An env whose episode ended on
        this step restarts its clock at 0; its ``info["terminal_observation"]`` carries
        the finished episode's final time."""

        def __init__(self, venv: Any, horizon: Optional[int] = None) -> None:
            super().__init__(venv, observation_space=timed_space(venv.observation_space))
            self.horizon = _horizon_of(venv, horizon)
            self._clock = np.zeros(venv.num_envs)

        def reset(self) -> np.ndarray:
            """Resets every env: time 0."""
            obs = self.venv.reset()
            self._clock[:] = 0
            return _appended(obs, self._clock, self.horizon, self.observation_space.dtype)

        def step_wait(self) -> Any:
            """The envs' step, one period later (0 where an episode began)."""
            obs, rewards, dones, infos = self.venv.step_wait()
            self._clock += 1
            dtype = self.observation_space.dtype
            for i in np.flatnonzero(dones):
                final = infos[i].get("terminal_observation")
                if final is not None:
                    infos[i]["terminal_observation"] = _appended(final, self._clock[i : i + 1], self.horizon, dtype)[0]
            self._clock[np.asarray(dones, dtype=bool)] = 0
            return _appended(obs, self._clock, self.horizon, dtype), rewards, dones, infos

    VecElapsedTimeObservation.__module__ = __name__
    VecElapsedTimeObservation.__qualname__ = "VecElapsedTimeObservation"
    return VecElapsedTimeObservation


def __getattr__(name: str) -> Any:
    # Lazy: stable-baselines3 (and torch) load only when the VecEnv wrapper is used.
    if name == "VecElapsedTimeObservation":
        return _vec_elapsed_time_class()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
