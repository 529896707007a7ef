"""Keeping what an imitation taught while reinforcement learning trains on.

PPO started from a copy of the planner's controller loses the copy within a few
hundred thousand steps (docs/main-job.md, "Keeping the imitation"): the observation
statistics it reads drift, its first updates follow the advantages of a value function
that has not learned yet, an exploration noise wider than the copy's margins steers its
updates, and nothing pulls the policy back in the states the copy handled and the
training rarely visits (Wołczyk et al., 2024). Besides a small noise
(:attr:`~chaincart_env.tools.compare.imitation.Imitation.action_std`), two remedies, set
by the scene's :class:`~chaincart_env.tools.compare.imitation.Imitation` (or ``compare
--critic-warmup`` and ``--imitation-weight``):

* :class:`CriticWarmup`: for the first env steps only the value function trains; the
  actor, its exploration noise included, is frozen (as PIRLNav, 2023, warms up its critic);
* :class:`ImitationAnchor`: the imitation's fit stays a second loss
  (:class:`~chaincart_env.tools.compare.policy_losses.AuxiliaryLoss`): the mean squared
  error between the policy's mean action and the planner's label, on minibatches of the
  imitation's labelled observations.

With either, the agent's observation statistics (``VecNormalize``) stay those the
imitation fitted the policy under (:func:`fix_statistics`): the copy reads
observations normalised with them, and as they moved toward the training's own states
the frozen copy lost success by itself (0.94 to 0.83 in 250k steps of a critic's
warm-up on ``transitions-2``). Both draw only from the global random states the
checkpoints keep, so a resumed run ends as the uninterrupted one does.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback

from chaincart_env.tools.compare.imitation import IMITATION_DATA_FILE, mean_action
from chaincart_env.tools.compare.policy_losses import AuxiliaryLoss, actor_parameters

__all__ = ["CriticWarmup", "ImitationAnchor", "fix_statistics"]


class CriticWarmup(BaseCallback):
    """Freezes the actor in every update made on the first ``steps`` env steps of the
    agent (a resumed run counts its earlier steps), so that only the value function learns."""

    def __init__(self, steps: int) -> None:
        super().__init__()
        self.steps = int(steps)
        self.frozen = False

    def _set(self, frozen: bool) -> None:
        for parameter in actor_parameters(self.model.policy):
            parameter.requires_grad_(not frozen)
        self.frozen = frozen

    def _on_training_start(self) -> None:
        self._set(self.model.num_timesteps < self.steps)

    def _on_step(self) -> bool:
        return True

    def _on_rollout_end(self) -> None:
        # The update that follows is the first on steps past the warm-up: the actor trains.
        if self.frozen and self.model.num_timesteps > self.steps:
            self._set(False)

    def _on_training_end(self) -> None:
        if self.frozen:
            self._set(False)


def fix_statistics(model: Any) -> None:
    """Keeps ``model``'s ``VecNormalize`` statistics as they are from now on (its
    ``training`` flag off: observations, and rewards where they are normalised, are
    normalised but no longer counted; the flag is saved with the envs of a checkpoint).
    Called before ``learn``, whose first reset would count its observations."""
    statistics = model.get_vec_normalize_env()
    if statistics is not None:
        statistics.training = False


class ImitationAnchor(AuxiliaryLoss):
    """The imitation's loss on minibatches of its data (``directory``'s
    :data:`IMITATION_DATA_FILE`: raw observations, normalised with the agent's current
    statistics, and the planner's labels)."""

    name = "imitation_loss"

    def __init__(self, directory: Path, weight: float) -> None:
        super().__init__(weight)
        with np.load(Path(directory) / IMITATION_DATA_FILE) as data:
            self.observations = data["observations"]
            self.labels = data["labels"]

    def loss(self, model: Any, size: int) -> Any:
        """The mean squared error to the planner's labels on ``size`` samples of the data."""
        import torch

        chosen = torch.randint(len(self.labels), (size,)).numpy()
        observed = self.observations[chosen]
        statistics = model.get_vec_normalize_env()
        if statistics is not None:
            observed = statistics.normalize_obs(observed)
        mean = mean_action(model.policy, torch.as_tensor(observed, dtype=torch.float32))
        return ((mean - torch.as_tensor(self.labels[chosen])) ** 2).mean()
