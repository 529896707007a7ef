"""Residual learning: an agent that corrects a model-based controller instead of
replacing it.

The base is the scene's model-based controller, designed on the env's nominal model
(:func:`base_controller`): where each episode starts at its target (the balancing
scenes), the paper's LQR; where the chain must travel, the planner's time-varying LQR
(:class:`~chaincart_env.policies.TrajectoryPolicy`) with one cached plan per pair of
equilibria (``plan_from="equilibrium"``) and no time limit on the planner, so that its
commands do not depend on the machine's load. At every step the env applies::

    u = clip(u_base + scale * clip(a, -1, 1), -1, 1)

``u_base`` the base's normalised command for the observation and ``a`` the agent's
action. The agent observes the env's observation followed by ``u_base``: it sees what it
corrects. An agent whose last layer starts near zero therefore starts as its base
controller, and training moves it only where a correction pays (a control delay the
design never saw, a model that is not the nominal one).

* :class:`ResidualAction` wraps one Gymnasium env (the RL Baselines3 Zoo's
  ``env_wrapper``);
* :class:`VecResidualAction` wraps a stable-baselines3 ``VecEnv`` (``compare`` and the
  leaderboard), each env's base episode restarted where its episode ends;
* :class:`ResidualPolicy` lets an agent trained so act on the plain env: it computes the
  base's command, asks the agent and returns the sum.

A trained agent carries its residual setting (:data:`RESIDUAL_ATTRIBUTE`: the scale,
the configuration its base was designed on and, if given, the base planner's cost
weights ``plan_weights``) in its saved file, so that every
evaluation wraps it the same way (:func:`residual_setting`, :func:`on_plain_env`). The history and the
elapsed time (:mod:`chaincart_env.history`, :mod:`chaincart_env.elapsed_time`) are
appended after the base's command, in that order.
"""

from __future__ import annotations

import functools
import math
import types
from typing import Any, Mapping, Optional

import gymnasium
import numpy as np

from chaincart_env.config import config_of
from chaincart_env.errors import InvalidInputError
from chaincart_env.history import PicklableVecWrapper

__all__ = [
    "DEFAULT_SCALE", "RESIDUAL_ATTRIBUTE", "RESIDUAL_VARIANT", "ResidualAction", "ResidualPolicy", "VecResidualAction",
    "base_controller", "check_scale", "checked_setting", "on_plain_env", "residual_keywords", "residual_setting",
    "residual_space",
]  # fmt: skip

#: The name of the variant: in env ids (``ChainCart-swingup-2-residual-v0``) and in
#: controller names (``ppo-residual``).
RESIDUAL_VARIANT = "residual"
#: The attribute of an SB3 model that records its residual setting (saved in its zip
#: file with the model's other attributes): ``{"scale": s, "config": {...}}``, and
#: ``"plan_weights"`` when the base plans with other cost weights than the planner's defaults.
RESIDUAL_ATTRIBUTE = "chaincart_residual"
#: The agent's weight against the force limit when none is given: a correction of up to a
#: fifth of the limit, enough to shift the base's timing under a delay, small enough that
#: the exploration noise of a new agent leaves the base's swing-up intact.
DEFAULT_SCALE = 0.2


def check_scale(scale: Any) -> float:
    """``scale`` as the weight of the agent's action: a number in (0, 2]."""
    if isinstance(scale, bool) or not isinstance(scale, (int, float, np.floating)) or not 0 < scale <= 2:
        raise InvalidInputError(f"residual scale = {scale!r}: expected a number in (0, 2] (the agent's share of "
                                "the force limit)")
    return float(scale)


def residual_keywords(value: Any) -> dict[str, Any]:
    """``value`` as :class:`ResidualAction`'s keywords, checked: ``{"scale": s}``, with
    ``"plan_weights"`` (the base planner's cost weights, every one) if given. A bare
    number is the scale alone, as training records before the weights had it."""
    if isinstance(value, (int, float, np.floating)) and not isinstance(value, bool):
        value = {"scale": value}
    if not isinstance(value, Mapping) or not set(value) <= {"scale", "plan_weights"}:
        raise InvalidInputError(f"residual = {value!r}: expected {{'scale': s}} and optionally 'plan_weights'")
    keywords: dict[str, Any] = {"scale": check_scale(value.get("scale", DEFAULT_SCALE))}
    if value.get("plan_weights") is not None:
        from chaincart_env.policies.planned import checked_plan_weights

        keywords["plan_weights"] = checked_plan_weights(value["plan_weights"])
    return keywords


def residual_space(observation_space: Any, action_space: Any) -> gymnasium.spaces.Box:
    """The env's observation space followed by the base's normalised command in [-1, 1]."""
    for space, what in ((observation_space, "observation"), (action_space, "action")):
        if not isinstance(space, gymnasium.spaces.Box) or len(space.shape) != 1:
            raise InvalidInputError(f"{what} space {space!r}: expected a one-dimensional Box")
    dim = action_space.shape[0]
    low = np.concatenate([np.asarray(observation_space.low, dtype=np.float64), -np.ones(dim)])
    high = np.concatenate([np.asarray(observation_space.high, dtype=np.float64), np.ones(dim)])
    dtype: Any = observation_space.dtype
    return gymnasium.spaces.Box(low=low.astype(dtype), high=high.astype(dtype), dtype=dtype)


def base_controller(config: Any, plan_weights: Optional[Mapping[str, float]] = None) -> Any:
    """The controller an agent on ``config`` (a ``ChainCartConfig``) corrects, designed
    on the nominal model: the LQR of the target where episodes start at it
    (``start="target"``: a plan from the target to itself is the LQR's hold, tracked
    less robustly), else the planner's time-varying LQR, one plan per pair of
    equilibria, the planner's iteration cap alone bounding its work (no wall-clock
    limit), with the cost weights ``plan_weights`` (``None``: the planner's defaults)."""
    from chaincart_env.policies import LQRPolicy, TrajectoryPolicy

    holder = types.SimpleNamespace(config=config)
    if config.start == "target":
        if plan_weights is not None:
            raise InvalidInputError(f"plan_weights = {plan_weights!r} on a scene whose episodes start at "
                                    "their target: expected none (its base is the LQR, which plans nothing)")
        return LQRPolicy.from_env(holder)
    # A pair whose plan misses its target is tracked all the same (its episodes fail), so
    # that one such pair among a scene's transitions does not stop a training.
    return TrajectoryPolicy.from_env(holder, plan_from="equilibrium", max_time=math.inf, on_failure="track",
                                     weights=plan_weights)


class _Base:
    """The base controller's commands for a batch, each env's episode restarted where told."""

    def __init__(self, config: Any, scale: float, plan_weights: Optional[Mapping[str, float]] = None) -> None:
        self.config, self.scale = config, check_scale(scale)
        self.policy = base_controller(config, plan_weights)
        self.commands = np.zeros((0, 0), dtype=np.float32)

    def observe(self, observations: np.ndarray, starts: Optional[np.ndarray]) -> np.ndarray:
        """The observations with the base's command for each appended (kept for :meth:`applied`)."""
        obs = np.asarray(observations)
        self.commands = self.policy.predict(obs, episode_start=starts)[0].reshape(obs.shape[0], -1)
        return np.concatenate([obs, self.commands], axis=1).astype(obs.dtype)

    def applied(self, actions: Any) -> np.ndarray:
        """What the env is sent: the base's last commands plus the scaled actions, within [-1, 1]."""
        correction = np.clip(np.asarray(actions, dtype=np.float64).reshape(self.commands.shape), -1.0, 1.0)
        return np.clip(self.commands + self.scale * correction, -1.0, 1.0).astype(np.float32)


class ResidualAction(gymnasium.Wrapper):
    """A Gymnasium env whose action corrects a model-based controller (module docstring):
    ``scale`` (in (0, 2]) weighs the agent's action against the force limit;
    ``plan_weights`` are the cost weights the base's planner uses (some of
    ``ChainCart.plan``'s ``weights``; ``None``: its defaults)."""

    def __init__(self, env: gymnasium.Env, scale: float = DEFAULT_SCALE,
                 plan_weights: Optional[Mapping[str, float]] = None) -> None:
        super().__init__(env)
        self._base = _Base(config_of(env), scale, plan_weights)
        self.scale = self._base.scale
        self.observation_space = residual_space(env.observation_space, env.action_space)

    def reset(self, *, seed: Optional[int] = None, options: Optional[dict[str, Any]] = None) -> tuple[np.ndarray, dict]:
        """The env's reset: its first observation and the base's first command."""
        obs, info = self.env.reset(seed=seed, options=options)
        return self._base.observe(np.asarray(obs)[None], np.ones(1, dtype=bool))[0], info

    def step(self, action: Any) -> tuple[np.ndarray, Any, bool, bool, dict]:
        """Sends the base's command plus the scaled action; the next observation with the base's next command."""
        obs, reward, terminated, truncated, info = self.env.step(self._base.applied(action)[0])
        return self._base.observe(np.asarray(obs)[None], np.zeros(1, dtype=bool))[0], reward, terminated, truncated, info


class ResidualPolicy:
    """An agent trained on a residual env (:class:`ResidualAction`,
    :class:`VecResidualAction`) acting on the plain env: each call appends the base's
    command to the observations, asks ``agent`` (wrapped for the history or elapsed time
    its observation space holds) and returns the sum the residual env would send.
    ``episode_start`` (SB3's convention) restarts an env's base episode; without it the
    base notices new episodes itself, as :class:`~chaincart_env.policies.TrajectoryPolicy` does."""

    def __init__(self, agent: Any, setting: Mapping[str, Any], observation_space: Any, action_space: Any,
                 horizon: int) -> None:
        from chaincart_env.config import ChainCartConfig
        from chaincart_env.elapsed_time import for_plain_env

        self._base = _Base(ChainCartConfig(**setting["config"]), setting["scale"], setting.get("plan_weights"))
        self.observation_space, self.action_space = observation_space, action_space
        self.agent = for_plain_env(agent, residual_space(observation_space, action_space), action_space, horizon)

    def predict(
        self, observation: Any, state: Any = None, episode_start: Any = None, deterministic: bool = True
    ) -> tuple[np.ndarray, Any]:
        """The base's command plus the agent's scaled correction, within [-1, 1]."""
        single = np.asarray(observation).ndim == 1
        obs = np.asarray(observation, dtype=self.observation_space.dtype).reshape(-1, self.observation_space.shape[0])
        starts = None if episode_start is None else np.asarray(episode_start, dtype=bool).reshape(-1)
        observed = self._base.observe(obs, starts)
        actions, state = self.agent.predict(observed, state=state, episode_start=episode_start,
                                            deterministic=deterministic)
        applied = self._base.applied(actions)
        return (applied[0] if single else applied), state

    def reset(self) -> None:
        """Forgets every env's episode, the base's and the agent's adapters' alike."""
        base_reset = getattr(self._base.policy, "reset", None)
        if callable(base_reset):  # the LQR keeps nothing from one step to the next
            base_reset()
        inner_reset = getattr(self.agent, "reset", None)
        if callable(inner_reset):
            inner_reset()


def on_plain_env(policy: Any, observation_space: Any, action_space: Any, horizon: int) -> Any:
    """``policy`` acting on an env with these spaces and episodes of ``horizon`` steps:
    through :class:`ResidualPolicy` if it records a residual setting, else adapted for
    the history and elapsed time its observation space holds
    (:func:`chaincart_env.elapsed_time.for_plain_env`)."""
    from chaincart_env.elapsed_time import for_plain_env

    setting = residual_setting(policy)
    if setting is not None:
        return ResidualPolicy(policy, setting, observation_space, action_space, horizon)
    return for_plain_env(policy, observation_space, action_space, horizon)


def residual_setting(agent: Any) -> Optional[dict[str, Any]]:
    """The residual setting an agent records (:data:`RESIDUAL_ATTRIBUTE`), or ``None``."""
    return checked_setting(getattr(agent, RESIDUAL_ATTRIBUTE, None))


def checked_setting(setting: Any) -> Optional[dict[str, Any]]:
    """``setting`` as a residual setting (``{"scale": s, "config": {...}}``, optionally
    ``"plan_weights"``; each checked), or ``None`` for ``None``."""
    if setting is None:
        return None
    if not isinstance(setting, Mapping) or not {"scale", "config"} <= set(setting) <= {"scale", "config", "plan_weights"}:
        raise InvalidInputError(f"{RESIDUAL_ATTRIBUTE} = {setting!r}: expected {{'scale': s, 'config': {{...}}}} "
                                "and optionally 'plan_weights'")
    keywords = residual_keywords({key: value for key, value in setting.items() if key != "config"})
    return {**keywords, "config": dict(setting["config"])}


@functools.cache
def _vec_residual_class() -> type:
    """:class:`VecResidualAction`, made once, on first use (stable-baselines3 loads then)."""
    from stable_baselines3.common.vec_env import VecEnvWrapper

    class VecResidualAction(PicklableVecWrapper, VecEnvWrapper):  # type: ignore[misc]
        """A stable-baselines3 ``VecEnv`` whose actions correct a model-based controller
        (:mod:`chaincart_env.residual`). An env whose episode ended on this step
        (same-step autoreset) begins a new base episode at its new first observation;
        its ``info["terminal_observation"]`` ends with zeros where the base's command
        would be (no command follows a final state)."""

        def __init__(self, venv: Any, scale: float = DEFAULT_SCALE,
                     plan_weights: Optional[Mapping[str, float]] = None) -> None:
            config = config_of(venv)
            super().__init__(venv, observation_space=residual_space(venv.observation_space, venv.action_space))
            self._base = _Base(config, scale, plan_weights)
            self.scale = self._base.scale

        def reset(self) -> np.ndarray:
            """Resets every env: first observations, new base episodes."""
            return self._base.observe(np.asarray(self.venv.reset()), np.ones(self.num_envs, dtype=bool))

        def step_async(self, actions: np.ndarray) -> None:
            """Sends the base's commands plus the scaled actions."""
            self.venv.step_async(self._base.applied(actions))

        def step_wait(self) -> Any:
            """The envs' step, each observation with the base's next command."""
            obs, rewards, dones, infos = self.venv.step_wait()
            width = self._base.commands.shape[1]
            for i in np.flatnonzero(dones):
                final = infos[i].get("terminal_observation")
                if final is not None:
                    infos[i]["terminal_observation"] = np.concatenate([final, np.zeros(width)]).astype(final.dtype)
            return self._base.observe(np.asarray(obs), np.asarray(dones, dtype=bool)), rewards, dones, infos

        @property
        def config(self) -> Any:
            """The configuration of the wrapped envs (what the base is designed on)."""
            return self._base.config

    VecResidualAction.__module__ = __name__
    VecResidualAction.__qualname__ = "VecResidualAction"
    return VecResidualAction


def __getattr__(name: str) -> Any:
    # Lazy: stable-baselines3 (and torch) load only when the VecEnv wrapper is used.
    if name == "VecResidualAction":
        return _vec_residual_class()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
