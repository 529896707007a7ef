"""Second losses on a PPO agent's policy, stepped beside PPO's own.

SB3's PPO minimises its clipped objective over minibatches of each rollout. A second
loss (keeping an imitation, :mod:`~chaincart_env.tools.compare.anchoring`; mirror
symmetry, :mod:`~chaincart_env.tools.compare.mirror_loss`) runs as a callback instead of
a changed training loop: after every rollout, as many minibatches as the update that
follows has, each one step of the policy's own optimizer (its learning rate, its Adam
moments, its gradient clipping) on ``weight`` times the loss. Alternating the two
steps approximates minimising their weighted sum. The minibatches are drawn from the
global torch random state, which the checkpoints keep, so a resumed run ends as the
uninterrupted one does.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback

__all__ = ["AuxiliaryLoss", "actor_parameters", "minibatches_per_update"]


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


class AuxiliaryLoss(BaseCallback):
    """After every rollout, :func:`minibatches_per_update` steps of the policy's
    optimizer on ``weight`` times :meth:`loss` of a minibatch of PPO's ``batch_size``;
    none while the actor is frozen (a critic's warm-up). The last rollout's mean loss
    (unweighted) is :attr:`last_loss` and SB3's ``train/<name>``."""

    #: The loss's name in SB3's log.
    name = "auxiliary_loss"

    def __init__(self, weight: float) -> None:
        super().__init__()
        self.weight = float(weight)
        self.last_loss = float("nan")

    def loss(self, model: Any, size: int) -> Any:
        """The loss (a scalar tensor, with gradients) on a minibatch of ``size``."""
        raise NotImplementedError

    def _on_step(self) -> bool:
        return True

    def _on_rollout_end(self) -> None:
        import torch

        model: Any = self.model  # PPO (a Gaussian actor-critic with minibatch updates)
        policy = model.policy
        if not any(p.requires_grad for p in actor_parameters(policy)):
            return
        losses = []
        policy.set_training_mode(True)
        for _ in range(minibatches_per_update(model)):
            loss = self.loss(model, int(model.batch_size))
            policy.optimizer.zero_grad()
            (self.weight * loss).backward()
            torch.nn.utils.clip_grad_norm_(policy.parameters(), model.max_grad_norm)
            policy.optimizer.step()
            losses.append(float(loss.detach()))
        policy.set_training_mode(False)
        self.last_loss = float(np.mean(losses))
        self.logger.record(f"train/{self.name}", self.last_loss)
