"""Keeping what an imitation taught while reinforcement learning trains on.

PPO started from a copy of the planner's controller loses the copy within a few
hundred thousand steps: its first updates follow the advantages of a value function
that has not learned yet, and nothing pulls the policy back in the states the copy
handled and the training rarely visits (Wołczyk et al., 2024). Two remedies, set by the
scene's :class:`~chaincart_env.tools.compare.imitation.Imitation` (or ``compare
--critic-warmup`` and ``--imitation-weight``):

* :class:`CriticWarmup`: for the first env steps only the value function trains; the
  actor, its exploration noise included, is frozen (as PIRLNav, 2023, warms up its critic);
* :class:`ImitationAnchor`: the imitation's fit stays a second loss. After every
  rollout, as many minibatches of the imitation's labelled observations as the update
  that follows has, each one step of the policy's own optimizer on ``weight`` times the
  mean squared error between the policy's mean action and the planner's label.

Both draw only from the global random states the checkpoints keep, so a resumed run
ends as the uninterrupted one does.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback

from chaincart_env.tools.compare.imitation import IMITATION_DATA_FILE, mean_action

__all__ = ["CriticWarmup", "ImitationAnchor", "actor_parameters", "minibatches_per_update"]


def actor_parameters(policy: Any) -> list[Any]:
    """The parameters of an SB3 actor-critic ``policy`` that move its actions: the
    actor's layers, its action head and its exploration noise (not the value function's)."""
    modules = [policy.mlp_extractor.policy_net, policy.action_net]
    if not policy.share_features_extractor:
        modules.append(policy.pi_features_extractor)
    return [p for module in modules for p in module.parameters()] + [policy.log_std]


def minibatches_per_update(model: Any) -> int:
    """How many minibatches one PPO update takes: ``n_epochs`` passes over the rollout."""
    rollout = int(model.n_steps) * int(model.n_envs)
    return int(model.n_epochs) * -(-rollout // int(model.batch_size))


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


class ImitationAnchor(BaseCallback):
    """After every rollout, :func:`minibatches_per_update` steps of the policy's
    optimizer on ``weight`` times the imitation's loss over minibatches of ``batch_size``
    drawn from the imitation's data (``directory``'s :data:`IMITATION_DATA_FILE`; raw
    observations, normalised with the agent's current statistics)."""

    def __init__(self, directory: Path, weight: float) -> None:
        super().__init__()
        with np.load(Path(directory) / IMITATION_DATA_FILE) as data:
            self.observations = data["observations"]
            self.labels = data["labels"]
        self.weight = float(weight)
        #: The mean loss of the last rollout's anchor steps (unweighted).
        self.last_loss = float("nan")

    def _on_step(self) -> bool:
        return True

    def _on_rollout_end(self) -> None:
        import torch

        model: Any = self.model  # PPO (a Gaussian actor-critic with minibatch updates)
        policy = model.policy
        if not any(p.requires_grad for p in actor_parameters(policy)):
            return  # the critic's warm-up: nothing of the actor trains yet
        statistics = model.get_vec_normalize_env()
        size, n = int(model.batch_size), len(self.labels)
        losses = []
        policy.set_training_mode(True)
        for _ in range(minibatches_per_update(model)):
            chosen = torch.randint(n, (size,)).numpy()
            observed = self.observations[chosen]
            if statistics is not None:
                observed = statistics.normalize_obs(observed)
            inputs = torch.as_tensor(observed, dtype=torch.float32)
            loss = ((mean_action(policy, inputs) - torch.as_tensor(self.labels[chosen])) ** 2).mean()
            policy.optimizer.zero_grad()
            (self.weight * loss).backward()
            torch.nn.utils.clip_grad_norm_(policy.parameters(), model.max_grad_norm)
            policy.optimizer.step()
            losses.append(float(loss.detach()))
        policy.set_training_mode(False)
        self.last_loss = float(np.mean(losses))
        self.logger.record("train/imitation_loss", self.last_loss)
