"""Robust training: the conditions a robust agent trains under.

An agent trained on the nominal system alone meets the leaderboard's axes (model
mismatch, sensor noise, force noise, control delay) for the first time when it is
scored on them. A robust agent trains on a distribution that covers them instead,
each drawn afresh at every episode's reset: masses and lengths within +-20 %,
observation noise, a multiplicative force disturbance and a control delay of 0 to 2
periods. Its recipe adds the last observations and actions to what it sees
(:mod:`chaincart_env.history`), so that it can tell which of its actions are still on
their way to the cart.

Every scene has a robust variant with its own Gymnasium id,
``ChainCart-<scene>-robust-v0`` (the scene plus :data:`ROBUST_CONDITIONS`), which RL
Baselines3 Zoo trains on with the ``-robust`` entries of the packaged hyperparameter
files; ``compare --policies ppo-robust`` and ``leaderboard --policies ppo-robust`` train
on the same conditions and evaluate on the scene itself.
"""

from __future__ import annotations

from typing import Any, Mapping

from chaincart_env.config import ChainCartConfig

__all__ = ["ROBUST_CONDITIONS", "ROBUST_VARIANT", "robust_config"]

#: The name of the variant: in env ids (``ChainCart-swingup-2-robust-v0``) and in
#: controller names (``ppo-robust``).
ROBUST_VARIANT = "robust"

#: The configuration keys a robust agent trains with, on top of the scene's.
ROBUST_CONDITIONS: Mapping[str, Any] = {
    "randomize": {"cart_mass": 0.2, "link_masses": 0.2, "link_lengths": 0.2},
    "obs_noise": 0.01,
    "force_noise": {"multiplicative": 0.2},
    "action_delay": (0, 2),
}


def robust_config(config: ChainCartConfig) -> ChainCartConfig:
    """``config`` with :data:`ROBUST_CONDITIONS` on top."""
    return config.replace(**ROBUST_CONDITIONS)
