"""Training recipes: the number of envs, the budget and the algorithm's keywords that
``compare`` uses for a scene unless told otherwise, kept in one table (as the RL
Baselines3 Zoo keeps hyperparameters per env).

A recipe is chosen by the scene's name and the algorithm; a scene without one trains
with :data:`GENERIC` (SB3's defaults). Command-line options (``--num-envs``,
``--timesteps``, ``--algo-kwarg``) override a recipe's entries one by one. How each
recipe was chosen is in ``docs/main-job.md``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

__all__ = ["GENERIC", "RECIPES", "TrainingRecipe", "recipe_for"]


@dataclass(frozen=True)
class TrainingRecipe:
    """How to train one algorithm on one scene."""

    num_envs: int
    timesteps: int
    hyperparameters: dict[str, Any] = field(default_factory=dict)
    #: Why these values, in a few words.
    reason: str = ""


#: SB3's defaults on 8 envs: what a scene without a recipe trains with.
GENERIC = TrainingRecipe(8, 400_000, {}, "SB3's defaults")

#: ``(scene, algorithm) -> recipe``.
RECIPES: dict[tuple[str, str], TrainingRecipe] = {
    # The planar double inverted pendulum: 32 envs with short rollouts and large
    # minibatches make PPO's updates cheap per env step, and a higher learning rate
    # makes up for the fewer, larger updates; the deterministic policy reaches every
    # evaluation start at about 140k steps (SB3's defaults on 8 envs: 250-400k).
    ("inverted-2", "ppo"): TrainingRecipe(
        32, 200_000, {"n_steps": 64, "batch_size": 512, "learning_rate": 1e-3},
        "tuned: 32 envs x 64-step rollouts, minibatch 512, learning rate 1e-3",
    ),
    # The same chain with masses and lengths redrawn within +-25% at every reset: the
    # same settings reach every evaluation start at about 210k steps.
    ("inverted-2-randomized", "ppo"): TrainingRecipe(
        32, 300_000, {"n_steps": 64, "batch_size": 512, "learning_rate": 1e-3},
        "as inverted-2, with a budget for the harder, randomised task",
    ),
}


def recipe_for(scene: str, algo: str) -> TrainingRecipe:
    """The recipe of ``scene`` and ``algo`` (any case), or :data:`GENERIC`."""
    return RECIPES.get((scene, algo.lower()), GENERIC)
