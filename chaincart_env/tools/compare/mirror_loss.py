"""Mirror symmetry as a second loss of a PPO agent.

The chain on its cart is symmetric under the reflection ``x_1 -> -x_1``
(:class:`~chaincart_env.symmetry.Mirror`): from the mirrored state the mirrored force
does what the force did, mirrored. So the best policy is equivariant, ``pi(M o) = M_a
pi(o)``, and an agent that learns a swing-up to one side has learned the other. The loss
(the mirror loss of Yu, Turk and Liu, 2018) is the mean squared difference between the
policy's mean action at the mirrored observation and the mirrored mean action, on
minibatches of the last rollout's observations, stepped as an
:class:`~chaincart_env.tools.compare.policy_losses.AuxiliaryLoss` beside PPO's. Where a
learner's data is mirrored too (Baek et al., 2024, with a replay buffer), the loss asks
the same of the policy without doubling the rollout.

Observations carrying a history (:mod:`chaincart_env.history`) mirror part by part;
observations normalised by ``VecNormalize`` are mirrored raw and normalised again.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from chaincart_env.config import ChainCartConfig
from chaincart_env.symmetry import Mirror
from chaincart_env.tools.compare.imitation import mean_action
from chaincart_env.tools.compare.policy_losses import AuxiliaryLoss
from chaincart_env.tools.compare.shaping import check_scale

__all__ = ["MIRROR_ALGOS", "MirrorLoss", "check_mirror_weight"]

#: The algorithms the loss serves: Gaussian actor-critics updated in minibatches.
MIRROR_ALGOS = ("ppo",)


def check_mirror_weight(weight: Any) -> float:
    """``weight`` as a float, or an InvalidInputError naming it (a finite number >= 0)."""
    return check_scale(weight, "mirror weight")


class MirrorLoss(AuxiliaryLoss):
    """The mirror loss on minibatches of the last rollout, for agents of ``config``'s
    scene observing ``history`` steps of history (and, with ``elapsed_time``, the
    elapsed time last, which the mirror leaves as it is)."""

    name = "mirror_loss"

    def __init__(self, config: ChainCartConfig, weight: float, history: int = 0, elapsed_time: bool = False) -> None:
        super().__init__(check_mirror_weight(weight))
        mirror = Mirror(config)
        signs = mirror.observation_signs(history)
        self.observation_signs = np.append(signs, 1.0).astype(signs.dtype) if elapsed_time else signs
        self.action_signs = mirror.action_signs()

    def mirrored(self, model: Any, observed: Any) -> Any:
        """The mirror images of observations as the policy sees them (normalised or not)."""
        statistics = model.get_vec_normalize_env()
        if statistics is None:
            return observed * self.observation_signs
        return statistics.normalize_obs(statistics.unnormalize_obs(observed) * self.observation_signs)

    def loss(self, model: Any, size: int) -> Any:
        """The mirror loss on ``size`` observations drawn from the last rollout."""
        import torch

        stored = model.rollout_buffer.observations
        observed = stored.reshape(-1, stored.shape[-1])
        chosen = torch.randint(observed.shape[0], (size,)).numpy()
        inputs = torch.as_tensor(observed[chosen], dtype=torch.float32)
        mirrored = torch.as_tensor(self.mirrored(model, observed[chosen]), dtype=torch.float32)
        signs = torch.as_tensor(self.action_signs, dtype=torch.float32)
        return ((mean_action(model.policy, mirrored) - signs * mean_action(model.policy, inputs)) ** 2).mean()
