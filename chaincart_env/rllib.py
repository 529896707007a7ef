"""Ray RLlib on chaincart: the native :class:`~chaincart_env.ChainCartVectorEnv` in
every env runner of a cluster (needs the ``rllib`` extra: ``ray[rllib]`` and torch).

* :func:`register` makes the env known to RLlib's env runners under :data:`ENV_NAME`.
* :func:`configure` sets up any RLlib ``AlgorithmConfig`` for chaincart;
  :func:`ppo_config` is a ``PPOConfig`` so set up, with PPO settings that mirror
  stable-baselines3's PPO defaults (the trainer of ``compare``).

What :func:`configure` sets:

* **The native vector env.** ``gym_env_vectorize_mode="vector_entry_point"``: each
  runner builds one ``ChainCartVectorEnv`` of ``num_envs_per_env_runner`` envs
  stepped in Rust. (RLlib's default, ``"sync"``, wraps single envs in Gymnasium's
  ``SyncVectorEnv``; :func:`make_runner_env` serves that mode too.)
* **The env config.** The scene and every keyword, validated once on the driver and
  passed to the runners as plain values (``ChainCartConfig.to_dict()``), plus the
  vector env's own keywords (``render_mode``, ...).
* **Autoreset.** RLlib's runners expect next-step autoreset (the step after an
  episode ended returns the next episode's first observation); any other
  ``autoreset_mode`` is a :class:`~chaincart_env.ChainCartError` naming it.
* **Start streams** (:func:`runner_start_seeds`). RLlib resets runner ``w`` (its
  worker index; 0 is the local runner) with ``seed + w``, and a plain vector env
  would seed its env ``i`` with ``seed + w + i``, so runner 1's env 1 and runner
  2's env 0 would share a stream. Here env ``i`` of that runner starts stream
  ``(seed + w) * num_envs + i``: runner ``w`` owns the block
  ``[(seed + w) * num_envs, (seed + w + 1) * num_envs)`` and no two envs of the
  cluster share a stream. Without a seed (``config.seed is None``) each runner
  draws its base from OS entropy (distinct with overwhelming probability, not
  reproducible).
* **Lost runners** (:data:`FAULT_TOLERANCE`). A runner whose process or node is
  lost is restarted by Ray with the same worker index: it re-seeds its envs into its
  own block (from the block's first seeds), never into another runner's. Training
  goes on with the other runners meanwhile; the steps the lost runner had sampled in
  the unfinished iteration are lost (at most its share of one train batch).
* **Threads.** In a runner process the Rust thread pool is sized to the CPUs Ray
  gave the runner (``RAYON_NUM_THREADS``, unless set), as Ray does for
  OpenMP/torch (``OMP_NUM_THREADS``), so many runners on one machine do not
  oversubscribe it. The driver's torch threads (the learner, when it runs in the
  driver) are the caller's choice: ``torch.set_num_threads(1)`` on small machines.
"""

from __future__ import annotations

import inspect
import math
import os
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, Callable, Optional, Sequence, Union

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv, VectorWrapper

from chaincart_env._core import ChainCartError
from chaincart_env.config import ChainCartConfig
from chaincart_env.env import ChainCartEnv, check_seed
from chaincart_env.vector import ChainCartVectorEnv, autoreset_mode_of

if TYPE_CHECKING:
    from ray.rllib.algorithms.algorithm_config import AlgorithmConfig
    from ray.rllib.algorithms.ppo import PPOConfig

__all__ = [
    "ENV_NAME",
    "FAULT_TOLERANCE",
    "PPO_TRAINING",
    "RunnerStartSeeds",
    "check_autoreset_mode",
    "configure",
    "env_config",
    "make_runner_env",
    "ppo_config",
    "register",
    "runner_start_seeds",
    "start_seeds_of",
]

#: The name :func:`register` gives the env in Ray's registry (``config.env``).
ENV_NAME = "chaincart"


def _keyword_only(cls: type) -> tuple[str, ...]:
    parameters = inspect.signature(cls).parameters.values()
    return tuple(p.name for p in parameters if p.kind == inspect.Parameter.KEYWORD_ONLY)


#: Keywords of ``ChainCartVectorEnv`` that are not ``ChainCartConfig`` keywords
#: (``autoreset_mode``, ``render_mode``, ...), passed through to the runners.
VECTOR_KEYWORDS = _keyword_only(ChainCartVectorEnv)
#: Those a single ``ChainCartEnv`` (RLlib's sync/async wrapping) does not take.
_VECTOR_ONLY = tuple(key for key in VECTOR_KEYWORDS if key not in _keyword_only(ChainCartEnv))

#: ``PPOConfig.training`` settings of :func:`ppo_config`: stable-baselines3's PPO
#: defaults (n_steps 2048 x 8 envs per update, minibatch 64, 10 epochs, lr 3e-4,
#: GAE lambda 0.95, clip 0.2, value loss 0.5, global gradient norm 0.5, no KL
#: penalty, no value clipping), so the two trainers are compared on equal terms.
PPO_TRAINING: dict[str, Any] = dict(
    lr=3e-4,
    gamma=0.99,
    lambda_=0.95,
    clip_param=0.2,
    num_epochs=10,
    minibatch_size=64,
    train_batch_size_per_learner=16_384,
    vf_loss_coeff=0.5,
    entropy_coeff=0.0,
    grad_clip=0.5,
    grad_clip_by="global_norm",
    use_kl_loss=False,
    vf_clip_param=math.inf,
)


#: ``AlgorithmConfig.fault_tolerance`` settings of :func:`configure`: an env runner
#: lost with its process or node is restarted by Ray (on any node with a free CPU)
#: with the same worker index, so it re-seeds its envs into its own block of start
#: seeds; RLlib samples with the other runners meanwhile and brings it back into
#: service when it answers again. Stated here rather than left to RLlib's defaults,
#: which changed across versions.
FAULT_TOLERANCE: dict[str, Any] = dict(
    restart_failed_env_runners=True,
    max_num_env_runner_restarts=1000,
    restart_failed_sub_environments=False,  # an env error is a bug: the runner fails and restarts whole
)


def register(name: str = ENV_NAME, creator: Optional[Callable[[Any], Any]] = None) -> str:
    """Registers ``creator`` (default :func:`make_runner_env`) with Ray under ``name``
    (default :data:`ENV_NAME`; Ray ships the creator to every runner of the cluster,
    where ``chaincart-env`` must be installed) and returns the name. Works in every
    Ray session of a process, also after ``ray.shutdown()`` and a new ``ray.init()``."""
    from ray.tune.registry import register_env

    _registry_for_this_session()
    register_env(name, make_runner_env if creator is None else creator)
    return name


def _registry_for_this_session() -> None:
    """Ray's env registry keys its entries by the job of the first Ray session of the
    process and keeps that key after ``ray.shutdown()``: in a later session, envs
    registered by name are invisible to the new job's runners. Let it take this
    session's job (a no-op where Ray's registry has no such cache)."""
    import ray
    from ray.tune import registry

    if not ray.is_initialized():
        return  # registered when a session starts, under that session's job
    current = ray.get_runtime_context().get_job_id()
    cached = getattr(registry._global_registry, "_prefix", current)
    if cached and cached != current:
        registry._global_registry._prefix = None


def check_autoreset_mode(env_keywords: Mapping[str, Any]) -> None:
    """Raises ChainCartError when ``env_keywords`` asks for an autoreset mode RLlib's
    runners cannot use (anything but next-step)."""
    value = env_keywords.get("autoreset_mode")
    if value is None:
        return
    if autoreset_mode_of(value) != AutoresetMode.NEXT_STEP:
        raise ChainCartError(
            f"autoreset_mode = {value!r} in the env config: RLlib's env runners need next-step autoreset "
            "(the step after an episode ends returns the next episode's first observation); "
            "leave autoreset_mode out or set it to 'next_step'"
        )


def env_config(config: Optional[ChainCartConfig | Mapping[str, Any]] = None, **env_keywords: Any) -> dict[str, Any]:
    """The validated env config for RLlib: every ``ChainCartConfig`` keyword as a plain
    value (from ``config`` and/or keywords) plus the vector env's own keywords."""
    check_autoreset_mode(env_keywords)
    vector = {key: env_keywords.pop(key) for key in VECTOR_KEYWORDS if key in env_keywords}
    if isinstance(config, Mapping) and not isinstance(config, ChainCartConfig):
        config = dict(config)
        check_autoreset_mode(config)
        vector.update({key: config.pop(key) for key in VECTOR_KEYWORDS if key in config})
    resolved = ChainCartConfig.coerce(config, **env_keywords)
    vector.setdefault("autoreset_mode", "next_step")
    return {**resolved.to_dict(), **vector}


def runner_start_seeds(runner_seed: Any, num_envs: int) -> list[int]:
    """The start seeds of a runner's envs when RLlib resets it with ``runner_seed``:
    env ``i`` gets ``runner_seed * num_envs + i`` (module docstring)."""
    base = check_seed(runner_seed)
    if (base + 1) * num_envs > 2**64:
        raise ChainCartError(
            f"runner seed = {base} with {num_envs} envs per runner: the block of start seeds "
            f"[{base * num_envs}, {(base + 1) * num_envs}) leaves [0, 2**64); expected a smaller seed"
        )
    return [base * num_envs + i for i in range(num_envs)]


class RunnerStartSeeds(VectorWrapper):
    """A vector env in an RLlib runner: ``reset(seed=s)`` with an int seeds the envs
    with :func:`runner_start_seeds` instead of ``s + i``; everything else passes
    through. ``start_seeds`` holds the seeds of the last seeded reset."""

    def __init__(self, env: VectorEnv) -> None:
        super().__init__(env)
        self.start_seeds: Optional[list[int]] = None

    def reset(
        self, *, seed: Optional[Union[int, Sequence[Optional[int]]]] = None, options: Optional[dict[str, Any]] = None
    ) -> tuple[Any, dict[str, Any]]:
        """Resets the wrapped vector env; an integer ``seed`` becomes this runner's
        :func:`runner_start_seeds` (kept in ``start_seeds``), anything else passes through."""
        if isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
            seeds = runner_start_seeds(seed, self.num_envs)
            self.start_seeds = seeds
            return self.env.reset(seed=seeds, options=options)  # type: ignore[arg-type]
        return self.env.reset(seed=seed, options=options)  # type: ignore[arg-type]


def start_seeds_of(env_runner: Any) -> Optional[list[int]]:
    """The start seeds of an RLlib env runner's envs (``None`` before a seeded reset or
    when its env is not a :class:`RunnerStartSeeds`), e.g. through
    ``algo.env_runner_group.foreach_env_runner(start_seeds_of)``."""
    env = getattr(env_runner, "env", None)
    while env is not None and not isinstance(env, RunnerStartSeeds):
        env = getattr(env, "env", None)
    return None if env is None else env.start_seeds


def _share_runner_threads() -> None:
    """In a Ray actor (an env runner): size the Rust pool to the actor's CPUs."""
    if "RAYON_NUM_THREADS" in os.environ:
        return
    try:
        import ray
    except ImportError:  # pragma: no cover - the creator only runs under Ray
        return
    if not ray.is_initialized() or ray.get_runtime_context().get_actor_id() is None:
        return  # the driver: its threads are the caller's choice
    cpus = ray.get_runtime_context().get_assigned_resources().get("CPU", 1.0)
    os.environ["RAYON_NUM_THREADS"] = str(max(1, math.floor(cpus)))


def make_runner_env(env_config: Mapping[str, Any]) -> Union[gym.Env, VectorEnv]:
    """RLlib's env creator (:func:`register`): with ``num_envs`` in the config (the
    vector entry point) a :class:`RunnerStartSeeds` around a ``ChainCartVectorEnv``;
    without it one ``ChainCartEnv`` (for RLlib's ``sync``/``async`` wrapping)."""
    keywords = dict(env_config)
    check_autoreset_mode(keywords)
    _share_runner_threads()
    num_envs = keywords.pop("num_envs", None)
    if num_envs is None:
        return ChainCartEnv(**{key: value for key, value in keywords.items() if key not in _VECTOR_ONLY})
    keywords["autoreset_mode"] = AutoresetMode.NEXT_STEP
    return RunnerStartSeeds(ChainCartVectorEnv(num_envs, **keywords))


def configure(
    algo_config: "AlgorithmConfig", config: Optional[ChainCartConfig | Mapping[str, Any]] = None, **env_keywords: Any
) -> "AlgorithmConfig":
    """Sets up ``algo_config`` (any RLlib ``AlgorithmConfig``) for chaincart in place
    and returns it: the registered env with the validated env config (``config`` and/or
    keywords: a scene and any ``ChainCartConfig`` or vector-env keyword), the native
    vector env in every runner, next-step autoreset and distinct start streams (module
    docstring)."""
    name = register()
    algo_config.environment(name, env_config=env_config(config, **env_keywords))
    algo_config.env_runners(gym_env_vectorize_mode=gym.VectorizeMode.VECTOR_ENTRY_POINT)
    algo_config.fault_tolerance(**FAULT_TOLERANCE)
    return algo_config


def ppo_config(config: Optional[ChainCartConfig | Mapping[str, Any]] = None, **env_keywords: Any) -> "PPOConfig":
    """A ``PPOConfig`` set up by :func:`configure` with :data:`PPO_TRAINING` and
    stable-baselines3's default network (64-64 tanh, separate policy and value nets,
    a state-independent log std). Change anything with the usual ``.training(...)``,
    ``.env_runners(num_env_runners=..., num_envs_per_env_runner=...)``, ``.debugging(seed=...)``."""
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.rllib.core.rl_module.default_model_config import DefaultModelConfig

    ppo = PPOConfig()
    configure(ppo, config, **env_keywords)
    ppo.training(**PPO_TRAINING)
    ppo.rl_module(
        model_config=DefaultModelConfig(
            fcnet_hiddens=[64, 64], fcnet_activation="tanh", vf_share_layers=False, free_log_std=True
        )
    )
    return ppo
