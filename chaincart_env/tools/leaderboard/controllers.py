"""The controllers a leaderboard compares, by the names ``--policies`` takes.

* Model-based, designed on the scene's nominal model: ``lqr`` (:class:`~chaincart_env.LQRPolicy`),
  ``energy``, ``trajectory`` and ``mpc`` (the large-motion controllers). Each is built
  with its class's ``from_env``.
* Learned: ``ppo``, ``sac``, ``td3``, trained on the scene with its packaged recipe
  (:mod:`chaincart_env.tools.compare.recipes`), one agent per seed, kept in the run
  directory and reused when the leaderboard runs again.

A controller that cannot serve a scene (the energy controller on a chain of two links,
say) is reported as such, not scored as a failure.
"""

from __future__ import annotations

import importlib
import time
from pathlib import Path
from typing import Any, Optional, Sequence

import numpy as np

from chaincart_env.config import ChainCartConfig
from chaincart_env.errors import InvalidInputError

__all__ = [
    "CONTROLLERS",
    "LEARNED",
    "MODEL_BASED",
    "NotApplicable",
    "TimedPolicy",
    "learned_agent",
    "model_based",
    "parse_controllers",
]

#: Model-based controllers: name -> (module, class).
MODEL_BASED: dict[str, tuple[str, str]] = {
    "lqr": ("chaincart_env.lqr", "LQRPolicy"),
    "energy": ("chaincart_env.policies", "EnergyPolicy"),
    "trajectory": ("chaincart_env.policies", "TrajectoryPolicy"),
    "mpc": ("chaincart_env.policies", "MPCPolicy"),
}
#: Learned controllers (stable-baselines3 algorithms).
LEARNED = ("ppo", "sac", "td3")
#: Every name ``--policies`` accepts.
CONTROLLERS = tuple(MODEL_BASED) + LEARNED


class NotApplicable(Exception):
    """The controller cannot serve this scene (with the reason)."""


def parse_controllers(text: str) -> list[str]:
    """``"ppo,lqr"`` into checked, distinct names in the given order."""
    names = [name.strip().lower() for name in text.split(",") if name.strip()]
    unknown = [name for name in names if name not in CONTROLLERS]
    if unknown or not names or len(set(names)) != len(names):
        raise InvalidInputError(
            f"--policies {text!r}: expected distinct names among {list(CONTROLLERS)}, separated by commas"
        )
    return names


def model_based(name: str, config: ChainCartConfig) -> Any:
    """The model-based controller ``name`` for ``config``'s scene, designed on its
    nominal model; :class:`NotApplicable` when it cannot serve the scene."""
    from chaincart_env.env import ChainCartEnv

    module, cls = MODEL_BASED[name]
    policy_class = getattr(importlib.import_module(module), cls)
    try:
        return policy_class.from_env(ChainCartEnv(config))
    except (ValueError, NotImplementedError) as error:
        raise NotApplicable(f"{name} on {config.scene}: {error}") from None


#: A tiny run's training settings on top of a recipe: rollouts and warm-up short enough
#: that a budget of a few thousand steps is several updates, not one oversized rollout.
TINY_TRAINING: dict[str, tuple[int, dict[str, Any]]] = {
    "ppo": (4, {"n_steps": 128, "batch_size": 128}),
    "sac": (4, {"learning_starts": 256, "buffer_size": 10_000}),
    "td3": (4, {"learning_starts": 256, "buffer_size": 10_000}),
}


def learned_agent(
    name: str, config: ChainCartConfig, seed: int, directory: Path, *, timesteps: Optional[int] = None,
    progress_bar: bool = False, tiny: bool = False,
) -> Any:
    """The agent ``name`` trained on ``config`` with seed ``seed`` (the scene's packaged
    recipe; ``timesteps`` overrides its budget; ``tiny``: :data:`TINY_TRAINING` on top),
    from ``directory`` if it was trained there before, else trained into it (a run that
    was cut short resumes)."""
    from chaincart_env.tools.compare.algorithms import algorithm_class
    from chaincart_env.tools.compare.recipes import recipe_for
    from chaincart_env.tools.compare.training import train

    directory = Path(directory)
    model_file = directory / "model.zip"
    if model_file.is_file():
        return algorithm_class(name).load(model_file, device="cpu")
    recipe = recipe_for(config.scene, name)
    budget = recipe.timesteps if timesteps is None else timesteps
    num_envs, hyperparameters = recipe.num_envs, dict(recipe.hyperparameters)
    if tiny:
        num_envs, small = TINY_TRAINING[name]
        hyperparameters.update(small)
    result = train(
        config, algo=name, timesteps=budget, seed=seed, num_envs=num_envs, directory=directory,
        eval_seeds=[10_000_000 + seed * 1000 + i for i in range(8)], eval_every=max(budget // 10, 1),
        checkpoint_every=max(budget // 5, 1), progress_bar=progress_bar, hyperparameters=hyperparameters,
        resume=True,
    )
    result.model.save(model_file)
    return result.model


class TimedPolicy:
    """A policy whose ``predict`` time is summed, per env-step served."""

    def __init__(self, policy: Any) -> None:
        self.policy = policy
        self.seconds = 0.0
        self.env_steps = 0

    def predict(
        self, observation: Any, state: Any = None, episode_start: Any = None, deterministic: bool = True
    ) -> tuple[np.ndarray, Any]:
        """The wrapped policy's ``predict``, timed."""
        start = time.perf_counter()
        out = self.policy.predict(observation, state=state, episode_start=episode_start, deterministic=deterministic)
        self.seconds += time.perf_counter() - start
        self.env_steps += int(np.atleast_2d(np.asarray(observation)).shape[0])
        return out

    def __getattr__(self, name: str) -> Any:  # bind() of oracle policies and the like
        return getattr(self.policy, name)

    def microseconds_per_step(self) -> float:
        """Mean compute time per env-step, microseconds (NaN before any step)."""
        return 1e6 * self.seconds / self.env_steps if self.env_steps else float("nan")


def seeds_checked(seeds: Sequence[int]) -> list[int]:
    """Distinct integers >= 0, at least one."""
    out = list(seeds)
    if not out or len(set(out)) != len(out) or any(isinstance(s, bool) or not isinstance(s, int) or s < 0 for s in out):
        raise InvalidInputError(f"seeds = {seeds!r}: expected distinct integers >= 0, at least one")
    return out
