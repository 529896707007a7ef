"""The controllers of a leaderboard: the model-based ones built with their class's
``from_env`` (:mod:`chaincart_env.tools.controllers`, the registry the main job uses
too), and the learned ones (``ppo``, ``sac``, ``td3``, ``ppo-robust``, ``ppo-residual``) trained on the
scene (or its robust variant) with their packaged recipe (:mod:`chaincart_env.tools.compare.recipes`), one agent per seed, kept
in the run directory and reused when the leaderboard runs again.

A shipped agent (``pretrained:<scene>/<name>``) acts as shipped on every scene with
its observation and action spaces (another scene than its own is a warning); on a
scene with other spaces it cannot act.

A controller that cannot serve a scene (the energy controller on a chain of two links,
say, or a shipped agent on a scene with other spaces) is reported as such, not scored
as a failure.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Optional, Sequence

import numpy as np

from chaincart_env.config import ChainCartConfig
from chaincart_env.errors import InvalidInputError

__all__ = [
    "DesignSource", "TINY_TRAINING", "TimedPolicy", "fixed_iteration_options", "fixed_source", "seeds_checked",
    "train_agent",
]  # fmt: skip


#: A tiny run's training settings on top of a recipe: rollouts and warm-up short enough
#: that a budget of a few thousand steps is several updates, not one oversized rollout.
TINY_TRAINING: dict[str, tuple[int, dict[str, Any]]] = {
    "ppo": (4, {"n_steps": 128, "batch_size": 128}),
    "sac": (4, {"learning_starts": 256, "buffer_size": 10_000}),
    "td3": (4, {"learning_starts": 256, "buffer_size": 10_000}),
}


def train_agent(
    name: str, config: ChainCartConfig, seed: int, directory: Path, *, timesteps: Optional[int] = None,
    progress_bar: bool = False, tiny: bool = False,
) -> None:
    """Trains the agent ``name`` on ``config`` with seed ``seed`` into ``directory``
    (the scene's packaged recipe; ``timesteps`` overrides its budget; ``tiny``:
    :data:`TINY_TRAINING` on top) and saves as ``model.zip`` (with its normalisation
    statistics beside it if the recipe normalises) the model that scored best on the
    periodic deterministic evaluations: PPO's success on the swing-ups rises and falls
    during training, so the last model can be a bad one, and compare reports the best
    too. Where compare polishes the scene's agents with the recipe's budget
    (:func:`~chaincart_env.tools.compare.stages.chosen_polish`), that best model is
    polished the same way and the polish's best is kept. A run that was cut short resumes from its checkpoint. The
    leaderboard reuses an agent whose ``model.zip`` exists."""
    from chaincart_env.tools.compare.curriculum import scene_curriculum, scene_training_reward
    from chaincart_env.tools.compare.imitation import scene_imitation
    from chaincart_env.tools.compare.normalization import copy_agent
    from chaincart_env.tools.compare.recipes import recipe_for, training_conditions
    from chaincart_env.tools.compare.run_files import BEST_MODEL_FILE, MODEL_FILE
    from chaincart_env.tools.compare.shaping import scene_shaping
    from chaincart_env.tools.compare.stages import chosen_polish
    from chaincart_env.tools.compare.training import train
    from chaincart_env.tools.controllers import CONTROLLERS

    directory = Path(directory)
    controller = CONTROLLERS[name]
    base, scene_methods = controller.recipe_algorithm, controller.takes_scene_methods
    warm_start_from = None
    if controller.fine_tunes:  # ppo-robust: the algorithm's nominal agent of this seed first, then fine-tuned
        from chaincart_env.tools.compare.stages import first_stage

        # The leaderboard's own agent of that algorithm and seed (agents/<scene>/<algo>/seed-<s>), where trained.
        nominal = directory.parents[1] / base / directory.name
        warm_start_from = first_stage(directory, lambda folder: train_agent(
            base, config, seed, folder, timesteps=timesteps, progress_bar=progress_bar, tiny=tiny), existing=nominal)
    recipe = recipe_for(config.scene, name)
    budget = recipe.timesteps if timesteps is None else timesteps
    num_envs, hyperparameters = recipe.num_envs, dict(recipe.hyperparameters)
    if tiny:
        num_envs, small = TINY_TRAINING[CONTROLLERS[name].recipe_algorithm]
        hyperparameters.update(small)
    imitation = None if tiny else scene_imitation(config.scene, name)
    polish = None if tiny or base != name else chosen_polish(config.scene, "scene", timesteps)
    methods = scene_methods and not tiny  # a residual agent's base is a model-based controller already
    if polish is not None:  # the recipe's agent first (its own budget given: not polished again)
        from chaincart_env.tools.compare.stages import POLISH_FIRST_STAGE_DIR, first_stage, polish_stage

        warm_start_from = first_stage(directory, lambda folder: train_agent(
            name, config, seed, folder, timesteps=recipe.timesteps, progress_bar=progress_bar),
            name=POLISH_FIRST_STAGE_DIR)
        budget, imitation = polish["timesteps"], None
        hyperparameters = polish_stage(name, {"hyperparameters": hyperparameters}, budget)["hyperparameters"]
    train(
        config, algo=name, timesteps=budget, seed=seed, num_envs=num_envs, directory=directory,
        eval_seeds=[EVALUATION_SEED_BASE + seed * 1000 + i for i in range(EVALUATION_STARTS)],
        eval_every=max(budget // EVALUATIONS, 1), checkpoint_every=max(budget // 5, 1),
        progress_bar=progress_bar, hyperparameters=hyperparameters, resume=True, normalize=recipe.normalize,
        imitation=imitation,
        curriculum=scene_curriculum(config.scene) if methods else None,
        training_reward=scene_training_reward(config.scene) if scene_methods else None, history=recipe.history,
        elapsed_time=recipe.elapsed_time, residual=recipe.residual,
        conditions=training_conditions(name, recipe, config), shaping=scene_shaping(config.scene) if methods else None,
        warm_start_from=warm_start_from,
    )
    copy_agent(directory / BEST_MODEL_FILE, directory / MODEL_FILE)


#: Periodic evaluations of a learned agent's training: how many over its budget, on how many
#: seeded starts (drawn apart from the leaderboard's cells, which start at seed 0).
EVALUATIONS, EVALUATION_STARTS, EVALUATION_SEED_BASE = 20, 20, 10_000_000


def fixed_iteration_options(name: str) -> dict[str, float]:
    """The options that take the wall clock out of controller ``name``'s work: no time
    limit on the planner (``max_time``) nor on MPC's step (``budget``), so that their
    iteration caps alone bound it and the same episodes give the same forces whatever
    the machine's load."""
    from chaincart_env.tools.controllers import CONTROLLERS

    if name == "mpc":
        return {"max_time": math.inf, "budget": math.inf}
    if name in CONTROLLERS and CONTROLLERS[name].plans:
        return {"max_time": math.inf}
    return {}


#: Model-based controllers built in this process, by source (a cell reuses its
#: controller's plans rather than planning again).
_DESIGNS: dict["DesignSource", Any] = {}


@dataclass(frozen=True)
class DesignSource:
    """A model-based controller as the leaderboard builds it: its class's ``from_env``
    on the scene's nominal model, with fixed iteration counts unless ``wall_clock``
    (then the planner's and MPC's default time limits too)."""

    name: str
    #: The scene's ``ChainCartConfig`` keywords as JSON (hashable, picklable).
    config: str
    wall_clock: bool = False

    @classmethod
    def of(cls, name: str, config: ChainCartConfig, wall_clock: bool = False) -> "DesignSource":
        """The source of ``name`` designed on ``config``."""
        return cls(name, json.dumps(config.to_dict(), sort_keys=True), wall_clock)

    def build(self) -> Any:
        """A new controller."""
        from chaincart_env.tools.controllers import build_model_based

        config = ChainCartConfig(**json.loads(self.config))
        options: dict[str, Any] = {} if self.wall_clock else dict(fixed_iteration_options(self.name))
        return build_model_based(self.name, config, **options)

    def load(self) -> Any:
        """The controller, built once per process."""
        if self not in _DESIGNS:
            _DESIGNS[self] = self.build()
        return _DESIGNS[self]


def fixed_source(name: str, config: ChainCartConfig, wall_clock: bool = False) -> Any:
    """The source (its ``load()`` gives the policy) of a controller the leaderboard does
    not train: a model-based one designed on ``config`` (:class:`DesignSource`, built
    once here to check that it serves the scene), or a shipped agent checked against
    ``config``'s spaces; ``NotApplicable`` when it cannot serve the scene."""
    from chaincart_env.pretrained_agents import is_pretrained_slot, parse_pretrained_slot, pretrained
    from chaincart_env.tools.compare.policy_sources import PolicySource
    from chaincart_env.tools.controllers import NotApplicable

    if not is_pretrained_slot(name):
        source = DesignSource.of(name, config, wall_clock)
        source.load()
        return source
    agent = pretrained(*parse_pretrained_slot(name, "--policies"))
    try:
        agent.check_config(config)
    except InvalidInputError as error:
        raise NotApplicable(str(error)) from None
    return PolicySource.pretrained(agent.scene, agent.name)


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
